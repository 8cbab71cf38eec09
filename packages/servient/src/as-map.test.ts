/**
 * `--as` / `--as-map` files as hostile input (size, nesting, unknown keys, names that are no URL segment),
 * the map checked against the device's TD and the twin's, and the default map inferred by name and shape.
 * The device TD is examples/as/desk-arm.td.json (shaped like a lab's uArm: integer millimetres).
 */
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { fileURLToPath } from "node:url";
import { afterAll, describe, expect, it } from "vitest";
import { AS_MAP_LIMITS, AS_TD_LIMITS, AsDeviceError, checkAsMap, checkDeviceTd, defaultAsMap, parseAsMap, readJsonFile } from "./as-map.js";
import { prepareDevice } from "./as-device.js";
import type { TdDocument } from "./twin-folder.js";

const EXAMPLES = fileURLToPath(new URL("../../../examples/as/", import.meta.url));
const DEVICE_FILE = join(EXAMPLES, "desk-arm.td.json");
const MAP_FILE = join(EXAMPLES, "desk-arm-on-kuka.map.json");
const device = (): TdDocument => JSON.parse(readFileSync(DEVICE_FILE, "utf8")) as TdDocument;
const exampleMap = (): Record<string, any> => JSON.parse(readFileSync(MAP_FILE, "utf8"));

/** A twin's TD with the affordances the maps name (a KUKA-like twin without a gripper). */
const TWIN: TdDocument = {
  title: "twin",
  properties: {
    getJointPosition: { type: "object", properties: { j1: { type: "number" }, j2: { type: "number" } } },
    getCartesianPosition: { type: "object", properties: { x: { type: "number" }, y: { type: "number" }, z: { type: "number" } } },
    motionStatus: { type: "object" },
  },
  actions: { moveToCartesianPosition: {}, moveToJointPosition: {}, stop: {} },
};

const dir = mkdtempSync(join(tmpdir(), "robwot-as-map-"));
afterAll(() => rmSync(dir, { recursive: true, force: true }));
let n = 0;
const file = (content: string): string => {
  const f = join(dir, `f${n++}.json`);
  writeFileSync(f, content);
  return f;
};
const mapOf = (doc: unknown): ReturnType<typeof parseAsMap> => {
  const f = file(JSON.stringify(doc));
  return parseAsMap(f, readJsonFile(f, "map", AS_MAP_LIMITS));
};

describe("the example map", () => {
  it("maps every affordance of the desk arm onto the twin", () => {
    const map = mapOf(exampleMap());
    checkAsMap(map, device(), TWIN);
    expect(map.frame).toEqual({ scale: 0.001, offset: [0.4, 0, 0.35] });
    expect(map.actions.get("goTo")).toEqual({ kind: "cartesian", speed: 0.3 });
    expect(map.actions.get("go")).toEqual({ kind: "cartesian", speed: { field: "speed", max: 10000 } });
    expect(map.actions.get("goHome")).toEqual({ kind: "joints", joints: "home" });
    expect(map.actions.get("beep")).toEqual({ kind: "unsupported" });
    expect(map.properties.get("location")).toEqual({ kind: "position" });
  });
});

describe("hostile files are refused naming the file and the reason", () => {
  it.each([
    ["larger than the cap", () => file(" ".repeat(AS_MAP_LIMITS.bytes + 1) + "{}"), /bytes, more than a map may have \(65536\)/],
    ["nested too deep", () => file("[".repeat(AS_MAP_LIMITS.depth + 1) + "]".repeat(AS_MAP_LIMITS.depth + 1)), /JSON nested 9 levels deep, more than a map may be \(8\)/],
    ["not JSON", () => file('{"frame": '), /not JSON \(map\)/],
    ["a folder", () => dir, /not a regular file \(map\)/],
    ["missing", () => join(dir, "nope.json"), /cannot be read \(map\): ENOENT/],
  ])("%s", (_what, make, why) => {
    const f = make();
    expect(() => readJsonFile(f, "map", AS_MAP_LIMITS)).toThrow(AsDeviceError);
    expect(() => readJsonFile(f, "map", AS_MAP_LIMITS)).toThrow(why);
    expect(() => readJsonFile(f, "map", AS_MAP_LIMITS)).toThrow(f);
  });

  it.each([
    ["an unknown top-level key", { ...exampleMap(), units: "mm" }, /units: unknown field \(known: frame, orientation, twin, actions, properties, events\)/],
    ["an unknown key of an entry", { ...exampleMap(), actions: { ...exampleMap().actions, goTo: { twin: "moveToCartesianPosition", sped: 1 } } }, /actions\.goTo\.sped: unknown field for moveToCartesianPosition/],
    ["a prototype key", JSON.parse('{"actions": {"__proto__": "unsupported"}}'), /actions\.__proto__: not a plain affordance name/],
    ["a scale of zero", { ...exampleMap(), frame: { scale: 0 } }, /frame\.scale: metres per device unit/],
    ["an offset of two numbers", { ...exampleMap(), frame: { scale: 0.001, offset: [0, 1] } }, /frame\.offset: expected \[x, y, z\]/],
    ["a quaternion that is not a unit one", { ...exampleMap(), orientation: { x: 0, y: 0, z: 0, w: 2 } }, /orientation: a unit quaternion, its norm is 2\.000/],
    ["a speed above 1", { ...exampleMap(), actions: { ...exampleMap().actions, goTo: { twin: "moveToCartesianPosition", speed: 3000 } } }, /actions\.goTo\.speed: a fraction/],
    ["an event mapped", { ...exampleMap(), events: { alarm: { twin: "collision" } } }, /events\.alarm: an event can only be "unsupported"/],
    ["a map that is an array", [], /\(top\): expected a JSON object, got an array/],
  ])("%s", (_what, doc, why) => {
    expect(() => mapOf(doc)).toThrow(why);
  });

  it("a device TD whose affordance name is no URL segment, or with too many affordances", () => {
    const td = device();
    (td.actions as Record<string, unknown>)["go/../x"] = { forms: [] };
    expect(() => checkDeviceTd("dev.json", td)).toThrow(/dev\.json: actions\.go\/\.\.\/x: not a plain name/);
    const many = Object.fromEntries(Array.from({ length: AS_TD_LIMITS.affordances + 1 }, (_, i) => [`a${i}`, {}]));
    expect(() => checkDeviceTd("dev.json", { title: "x", actions: many })).toThrow(/257 affordances, more than 256/);
    expect(() => checkDeviceTd("dev.json", { title: "" })).toThrow(/title: expected a non-empty string/);
  });
});

describe("the map against the TDs", () => {
  const check = (doc: Record<string, any>): void => checkAsMap(mapOf(doc), device(), TWIN);

  it("refuses a device affordance without an entry, naming it", () => {
    const doc = exampleMap();
    delete doc.actions.beep;
    expect(() => check(doc)).toThrow(/actions\.beep: the device's action has no entry \(name the twin's, or say "unsupported": it then answers 501\)/);
  });

  it("refuses a twin without the gripper action the map names", () => {
    const doc = exampleMap();
    doc.actions.gripOpen = { twin: "gripOpen" };
    expect(() => check(doc)).toThrow(/actions\.gripOpen: the twin has no action gripOpen \(its actions: moveToCartesianPosition, moveToJointPosition, stop\)/);
  });

  it("refuses an entry for an affordance the device lacks, a device input field without counterpart, a missing frame", () => {
    expect(() => check({ ...exampleMap(), properties: { ...exampleMap().properties, speed: "unsupported" } })).toThrow(/properties\.speed: the device has no such property/);
    const go = exampleMap();
    go.actions.go = { twin: "moveToCartesianPosition" };
    expect(() => check(go)).toThrow(/actions\.go: the device's input field\(s\) speed have no counterpart/);
    const noFrame = exampleMap();
    delete noFrame.frame;
    expect(() => check(noFrame)).toThrow(/frame: required: the device's positions are mapped/);
    const joints = exampleMap();
    joints.actions.goHome = { twin: "moveToJointPosition", joints: { j1: 0 } };
    expect(() => check(joints)).toThrow(/actions\.goHome\.joints: every joint of the twin exactly once \(unknown: none; missing: j2\)/);
  });

  it("prepareDevice refuses a device input schema that cannot be compiled, naming the action", () => {
    const td = device();
    (td.actions as Record<string, any>)["goTo"].input.properties.x.type = "integr";
    const f = file(JSON.stringify(td));
    expect(() => prepareDevice({ name: "desk-arm", td: f, map: MAP_FILE }, new Map([["kuka", TWIN]]), new Set())).toThrow(/actions\.goTo\.input: not a usable JSON schema: schema is invalid/);
  });

  it("prepareDevice refuses a name that is taken or no URL segment", () => {
    expect(() => prepareDevice({ name: "things", td: DEVICE_FILE, map: MAP_FILE }, new Map([["kuka", TWIN]]), new Set(["things"]))).toThrow(/the URL path \/things is taken/);
    expect(() => prepareDevice({ name: "a/b", td: DEVICE_FILE, map: MAP_FILE }, new Map([["kuka", TWIN]]), new Set())).toThrow(/1-64 of A-Z a-z 0-9 _ -/);
    expect(prepareDevice({ name: "desk-arm", td: DEVICE_FILE, map: MAP_FILE }, new Map([["kuka", TWIN]]), new Set()).map.actions.size).toBe(10);
  });
});

describe("sequences and the twin answering", () => {
  const WITH_GRIPPER: TdDocument = { ...TWIN, actions: { ...TWIN.actions, gripOpen: {}, gripClose: {} } };
  /** the desk arm's goHome (no input) as a pick: above, down, grip, up, home */
  const pick = (): Record<string, any> => ({
    ...exampleMap(),
    actions: {
      ...exampleMap().actions,
      goHome: { sequence: [
        { twin: "moveToCartesianPosition", position: { x: 150, y: 0, z: 100 } },
        { twin: "moveToCartesianPosition", position: { x: 150, y: 0, z: 60 }, speed: 0.2 },
        { twin: "gripClose" },
        { twin: "moveToJointPosition", joints: "home" },
      ] },
    },
  });

  it("a device action without input maps to the twin's actions in order, each step checked", () => {
    const map = mapOf(pick());
    checkAsMap(map, device(), WITH_GRIPPER);
    expect(map.actions.get("goHome")).toEqual({ kind: "sequence", steps: [
      { rule: { kind: "cartesian" }, position: { x: 150, y: 0, z: 100 } },
      { rule: { kind: "cartesian", speed: 0.2 }, position: { x: 150, y: 0, z: 60 } },
      { rule: { kind: "direct", twin: "gripClose" } },
      { rule: { kind: "joints", joints: "home" } },
    ] });
    expect(() => checkAsMap(map, device(), TWIN)).toThrow(/actions\.goHome\.sequence\[2\]: the twin has no action gripClose/);
  });

  it("refuses a sequence on an action with input, a Cartesian step without a position, too many steps", () => {
    const withInput = pick();
    withInput.actions.goTo = withInput.actions.goHome;
    withInput.actions.goHome = { twin: "moveToJointPosition", joints: "home" };
    expect(() => checkAsMap(mapOf(withInput), device(), WITH_GRIPPER)).toThrow(/actions\.goTo: the device's action takes an input; a sequence of fixed steps takes none/);
    const bare = pick();
    delete bare.actions.goHome.sequence[0].position;
    expect(() => mapOf(bare)).toThrow(/actions\.goHome\.sequence\[0\]\.position: a moveToCartesianPosition step needs a position/);
    const long = pick();
    long.actions.goHome.sequence = Array.from({ length: 33 }, () => ({ twin: "gripClose" }));
    expect(() => mapOf(long)).toThrow(/actions\.goHome\.sequence: 1 to 32 steps/);
  });

  it("prepareDevice takes the twin the map names; with several twins a map must name one that is served", () => {
    const twins = new Map([["uarm", WITH_GRIPPER], ["dobot", WITH_GRIPPER]]);
    const named = file(JSON.stringify({ ...pick(), twin: "dobot" }));
    expect(prepareDevice({ name: "desk-arm", td: DEVICE_FILE, map: named }, twins, new Set()).twin).toBe("dobot");
    expect(() => prepareDevice({ name: "desk-arm", td: DEVICE_FILE, map: file(JSON.stringify(pick())) }, twins, new Set())).toThrow(/2 twins are served: its --as-map must name the one that answers as the device \("twin": one of uarm, dobot\)/);
    const elsewhere = file(JSON.stringify({ ...pick(), twin: "ur5" }));
    expect(() => prepareDevice({ name: "desk-arm", td: DEVICE_FILE, map: elsewhere }, twins, new Set())).toThrow(/twin: no twin is served at \/ur5/);
  });
});

describe("the default map", () => {
  it("infers positions in millimetres from integer x, y, z (or a unit) and same-named affordances", () => {
    const td: TdDocument = {
      title: "small",
      actions: { goTo: device().actions!["goTo"]!, stop: {} },
      properties: { location: { type: "object", properties: { x: { type: "number", unit: "mm" }, y: { type: "number", unit: "mm" }, z: { type: "number", unit: "mm" } } } },
    };
    const map = defaultAsMap("small.json", td, TWIN);
    checkAsMap(map, td, TWIN);
    expect(map.frame).toEqual({ scale: 0.001, offset: [0, 0, 0] });
    expect(map.orientation).toBe("keep");
    expect(map.actions.get("goTo")).toEqual({ kind: "cartesian" });
    expect(map.actions.get("stop")).toEqual({ kind: "direct", twin: "stop" });
    expect(map.properties.get("location")).toEqual({ kind: "position" });
  });

  it("refuses what it cannot infer, naming every such affordance", () => {
    // goTo and location are inferred (integer x, y, z: millimetres); homeLoc is writable: a setting
    expect(() => defaultAsMap("desk-arm.td.json", device(), TWIN)).toThrow(
      /desk-arm\.td\.json: no map can be inferred for actions\.go, actions\.goHome, actions\.gripOpen, actions\.gripClose, actions\.beep, actions\.beepWithTime, actions\.reset, actions\.turnLeft, actions\.turnRight, properties\.homeLoc: write one \(--as-map FILE/,
    );
    const unitless: TdDocument = { title: "u", actions: { goTo: { input: { type: "object", properties: { x: { type: "number" }, y: { type: "number" }, z: { type: "number" } } } } } };
    expect(() => defaultAsMap("u.json", unitless, TWIN)).toThrow(/no map can be inferred for actions\.goTo \(x, y, z are numbers without a unit\)/);
  });
});
