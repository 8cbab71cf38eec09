/**
 * `robwot serve TWIN --as DEVICE=real-td.json --as-map map.json`: the KUKA twin answers as a desk arm
 * shaped like a lab's uArm (examples/as/: integer millimetres, goTo/go/goHome, location, gripper, beep).
 * The served TD is the device's own with our forms; a node-wot consumer of it moves the twin with goTo in
 * millimetres and reads location back in integer millimetres; the device's schema refuses what it would
 * (400), the twin refuses what it cannot reach (422: problem details, or the error shape the device's TD
 * declares); affordances the map leaves out are refused at start, "unsupported" ones answer 501; a hostile
 * map stops `robwot serve` with exit code 2. Real servient, backend and HTTP.
 */
import { mkdtempSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { validateThingDescription } from "@robwot/core";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO, runCli } from "./cli-run.js";
import { openSse } from "./helpers/sse.js";
import { consumer, generateTwin, http, invoke, waitState } from "./serve-helpers.js";

const EXAMPLE_TD = join(REPO, "examples", "as", "desk-arm.td.json");
const EXAMPLE_MAP = join(REPO, "examples", "as", "desk-arm-on-kuka.map.json");
const dir = mkdtempSync(join(tmpdir(), "robwot-serve-as-"));
const exampleMap = (): Record<string, any> => JSON.parse(readFileSync(EXAMPLE_MAP, "utf8"));
/** The map's frame: device millimetres -> the twin's metres. */
const twinM = (mm: { x: number; y: number; z: number }): number[] => [mm.x * 0.001 + 0.4, mm.y * 0.001, mm.z * 0.001 + 0.35];

let folder: string;
let running: RunningServient;
let twinBase: string;
let base: string;
/** the device TD as written, with a declared error response on `go` (the example has none, as the lab's) */
let deviceTd: Record<string, any>;
let tdFile: string;

beforeAll(async () => {
  folder = await generateTwin("kuka_iiwa", 3000);
  deviceTd = JSON.parse(readFileSync(EXAMPLE_TD, "utf8"));
  deviceTd.schemaDefinitions = { failure: { type: "object", properties: { message: { type: "string" }, status: { type: "integer" } } } };
  deviceTd.actions.go.forms[0].additionalResponses = [{ success: false, contentType: "application/json", schema: "failure" }];
  // observable, as the lab's location is over MQTT: served as an SSE stream
  deviceTd.properties.location.observable = true;
  tdFile = join(dir, "desk-arm.td.json");
  writeFileSync(tdFile, JSON.stringify(deviceTd));
  running = await startServient({ twins: [folder], port: 0, realtime: 0, as: [{ name: "desk-arm", td: tdFile, map: EXAMPLE_MAP }] });
  twinBase = running.things[0]!.tdUrl;
  base = `${running.url}/desk-arm`;
});
afterAll(async () => {
  await running?.stop();
});

async function twinPose(): Promise<{ x: number; y: number; z: number; orientation: { x: number; y: number; z: number; w: number } }> {
  return (await http(`${twinBase}/properties/getCartesianPosition`)).body;
}

describe("the served TD", () => {
  it("is the device's own: its title, names, schemas and integer ranges; our HTTP forms, security and id; listed beside the twin", async () => {
    const td = (await http(base)).body;
    expect(td.title).toBe("DeskArm");
    // a valid TD (the official TD schema and assertions), as the twin's own
    expect((await validateThingDescription(td)).errors).toEqual([]);
    expect(Object.keys(td.actions)).toEqual(Object.keys(deviceTd.actions));
    expect(Object.keys(td.properties)).toEqual(Object.keys(deviceTd.properties));
    expect(td.actions.goTo.input).toEqual(deviceTd.actions.goTo.input);
    expect(td.properties.location.properties).toEqual(deviceTd.properties.location.properties);
    expect(td.actions.goTo.input.properties.x).toEqual({ type: "integer", minimum: 120, maximum: 200 });
    const forms = [...Object.values(td.actions), ...Object.values(td.properties)].flatMap((a: any) => a.forms);
    for (const f of forms) expect(f.href.startsWith(`${base}/`), f.href).toBe(true);
    expect(JSON.stringify(td)).not.toMatch(/mqtt|https:\/\/arm|lab\.example|basic_sc/);
    expect(td.securityDefinitions).toEqual({ nosec_sc: { scheme: "nosec" } });
    expect(td.id).not.toBe(deviceTd.id);
    expect(td.id).toBe(`${running.things[0]!.id}:as:desk-arm`);
    expect(running.devices).toEqual([{ name: "desk-arm", id: td.id, title: "DeskArm", tdUrl: base, twin: running.things[0]!.slug }]);
    const listed = (await http(`${running.url}/things`)).body.map((t: { id: string }) => t.id);
    expect(listed).toEqual(expect.arrayContaining([running.things[0]!.id, td.id]));
    expect((await http(`${running.url}/things/${encodeURIComponent(td.id)}`)).body.title).toBe("DeskArm");
  });
});

describe("a node-wot consumer of the device's TD", () => {
  it("moves the twin with goTo in millimetres and reads location back in integer millimetres", async () => {
    const c = await consumer();
    try {
      const thing = await c.wot.consume((await http(base)).body);
      for (const target of [
        { x: 160, y: -50, z: 80 },
        { x: 187, y: 123, z: 61 },
      ]) {
        await thing.invokeAction("goTo", target);
        const pose = await twinPose();
        const want = twinM(target);
        [pose.x, pose.y, pose.z].forEach((v, i) => expect(Math.abs(v - want[i]!), `${["x", "y", "z"][i]} of ${JSON.stringify(pose)}`).toBeLessThan(1e-3));
        // the map's fixed orientation: the tool points down
        expect(Math.abs(pose.orientation.y)).toBeGreaterThan(0.999);
        const location = (await (await thing.readProperty("location")).value()) as Record<string, number>;
        expect(location).toEqual(target);
        for (const v of Object.values(location)) expect(Number.isInteger(v)).toBe(true);
      }
      // go: the device's speed field is the twin's speed fraction (5000 of 10000)
      await thing.invokeAction("go", { x: 130, y: 100, z: 60, speed: 5000 });
      expect(await (await thing.readProperty("location")).value()).toEqual({ x: 130, y: 100, z: 60 });
    } finally {
      await c.stop();
    }
  });
});

describe("the location stream", () => {
  it("an observable position property streams the twin's pose in the device's units over SSE", async () => {
    const td = (await http(base)).body;
    const form = td.properties.location.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse");
    expect(form).toMatchObject({ href: `${base}/properties/location/sse`, op: ["observeproperty", "unobserveproperty"] });
    expect(td.properties.homeLoc.forms.map((f: { op: string[] }) => f.op)).toEqual([["readproperty"]]);
    const stream = await openSse(form.href);
    try {
      const now = (await http(`${base}/properties/location`)).body;
      await stream.wait((m) => m.length >= 1);
      expect(stream.events()[0]!.data).toEqual(now);
      const target = { x: now.x === 150 ? 151 : 150, y: 20, z: 75 };
      expect((await invoke(base, "goTo", target)).status).toBe(204);
      await stream.wait((m) => m.some((e) => e.data === JSON.stringify(target)));
    } finally {
      stream.close();
    }
  });
});

describe("inputs and refusals", () => {
  it.each([
    [{ x: 250, y: 0, z: 80 }, /\/x must be <= 200/],
    [{ x: 150.5, y: 0, z: 80 }, /\/x must be integer/],
    [{ x: 150, y: 0 }, /missing required property 'z'/],
    [{ x: 150, y: 0, z: 80, w: 1 }, /unknown property 'w'/],
  ])("goTo %j answers 400 naming the field", async (input, why) => {
    const before = await twinPose();
    const r = await invoke(base, "goTo", input);
    expect(r.status).toBe(400);
    expect(r.type).toMatch(/application\/problem\+json/);
    expect(r.body.detail).toMatch(why);
    expect(await twinPose()).toEqual(before);
  });

  it("a target the twin refuses answers 422: problem details with the twin's reasons, or the device's declared error shape", async () => {
    const target = { x: 160, y: 0, z: 70 };
    const add = await invoke(twinBase, "addObstacle", { name: "block", shape: { type: "box", size: [0.06, 0.06, 0.06] }, position: twinM(target) });
    expect(add.status).toBe(200);
    try {
      const before = await twinPose();
      const r = await invoke(base, "goTo", target);
      expect(r.status).toBe(422);
      expect(r.type).toMatch(/application\/problem\+json/);
      expect(r.body.code).toBe("E_REJECTED");
      expect(r.body.details.reasons.join(" ")).toMatch(/touches block/);
      const shaped = await invoke(base, "go", { ...target, speed: 3000 });
      expect(shaped.status).toBe(422);
      expect(shaped.type).toMatch(/^application\/json/);
      expect(Object.keys(shaped.body).sort()).toEqual(["message", "status"]);
      expect(shaped.body.status).toBe(422);
      expect(shaped.body.message).toMatch(/touches block/);
      expect(await twinPose()).toEqual(before);
    } finally {
      await invoke(twinBase, "removeObstacle", { name: "block" });
    }
  });

  it("a goTo while the twin moves answers 409 E_BUSY: the twin's own move guard holds", async () => {
    const answers = await Promise.all([invoke(base, "goTo", { x: 170, y: 60, z: 90 }), invoke(base, "goTo", { x: 140, y: -60, z: 60 })]);
    expect(answers.map((r) => r.status).sort()).toEqual([204, 409]);
    expect(answers.find((r) => r.status === 409)!.body.code).toBe("E_BUSY");
  });

  it("goHome moves the twin to its home pose; unsupported affordances answer 501 problem details", async () => {
    expect((await invoke(base, "goHome", "")).status).toBe(204);
    const q = (await http(`${twinBase}/properties/getJointPosition`)).body as Record<string, number>;
    for (const v of Object.values(q)) expect(Math.abs(v)).toBeLessThan(1e-6);
    for (const r of [await invoke(base, "beep", ""), await invoke(base, "gripOpen", ""), await http(`${base}/properties/homeLoc`)]) {
      expect(r.status).toBe(501);
      expect(r.body.code).toBe("E_NOT_IMPLEMENTED");
      expect(r.body.detail).toMatch(/not served by the twin behind this Thing \(its map says "unsupported"\)/);
    }
  });
});

describe("refused at start", () => {
  const start = (map: unknown): Promise<RunningServient> => {
    const file = join(dir, `map-${Math.random().toString(36).slice(2)}.json`);
    writeFileSync(file, typeof map === "string" ? map : JSON.stringify(map));
    return startServient({ twins: [folder], port: 0, as: [{ name: "desk-arm", td: tdFile, map: file }] });
  };

  it("a device affordance the map does not cover, and a twin action the twin lacks, each named", async () => {
    const unmapped = exampleMap();
    delete unmapped.actions.turnLeft;
    await expect(start(unmapped)).rejects.toThrow(/actions\.turnLeft: the device's action has no entry/);
    const twinActions = Object.keys(JSON.parse(readFileSync(join(folder, "td.json"), "utf8")).actions);
    const gripper = { ...exampleMap(), actions: { ...exampleMap().actions, gripOpen: { twin: "gripOpen" } } };
    // a twin with a gripper serves gripOpen itself; the KUKA of this test has none
    if (!twinActions.includes("gripOpen")) await expect(start(gripper)).rejects.toThrow(/actions\.gripOpen: the twin has no action gripOpen/);
    await expect(start({ ...exampleMap(), actions: { ...exampleMap().actions, beep: { twin: "beep" } } })).rejects.toThrow(/actions\.beep: the twin has no action beep \(its actions: moveToJointPosition/);
  });

  it("robwot serve with a hostile map exits 2 naming the file and the reason, before any backend starts", async () => {
    const cases: [string, RegExp][] = [
      [JSON.stringify({ ...exampleMap(), units: "mm" }), /units: unknown field/],
      ["[".repeat(40) + "]".repeat(40), /JSON nested 40 levels deep, more than a map may be \(8\)/],
      [`{"frame": ${" ".repeat(70_000)}}`, /bytes, more than a map may have \(65536\)/],
      ['{"actions": {"goTo": ', /not JSON \(map\)/],
    ];
    for (const [text, why] of cases) {
      const file = join(dir, `hostile-${Math.random().toString(36).slice(2)}.json`);
      writeFileSync(file, text);
      const r = await runCli(["serve", folder, "--port", "0", "--as", `desk-arm=${tdFile}`, "--as-map", file], { timeoutMs: 30_000 });
      expect(r.code, r.stderr).toBe(2);
      expect(r.stderr).toMatch(/^robwot: error: /);
      expect(r.stderr).toContain(file);
      expect(r.stderr).toMatch(why);
      expect(r.stderr).not.toMatch(/\n\s+at /);
    }
  });
});

describe("a twin with a gripper (generate --gripper suction), behind --auth, in real time", () => {
  it("answers the device's gripClose / gripOpen with its own actions of those names; the device's TD and routes take our credentials; the twin's stop ends a goTo (409)", async () => {
    const gripperTwin = await generateTwin("kuka_iiwa", 3000, ["--gripper", "suction"]);
    const map = { ...exampleMap(), actions: { ...exampleMap().actions, gripOpen: { twin: "gripOpen" }, gripClose: { twin: "gripClose" } } };
    const file = join(dir, "gripper.map.json");
    writeFileSync(file, JSON.stringify(map));
    const s = await startServient({ twins: [gripperTwin], port: 0, realtime: 1, auth: { scheme: "bearer", token: "t0k" }, as: [{ name: "desk-arm", td: tdFile, map: file }] });
    try {
      const device = `${s.url}/desk-arm`;
      const auth = { authorization: "Bearer t0k" };
      expect((await http(device)).status).toBe(401);
      expect((await invoke(device, "gripClose", "")).status).toBe(401);
      const td = (await http(device, { headers: auth })).body;
      expect(td.securityDefinitions).toEqual({ bearer_sc: { scheme: "bearer", in: "header" } });
      expect(td.security).toBe("bearer_sc");
      const gripper = async (): Promise<{ state: string }> => (await http(`${s.things[0]!.tdUrl}/properties/gripper`, { headers: auth })).body;
      // the device declares no output: 204, as the device answers
      expect((await invoke(device, "gripClose", "", auth)).status).toBe(204);
      expect((await gripper()).state).toBe("closed");
      expect((await invoke(device, "gripOpen", "", auth)).status).toBe(204);
      expect((await gripper()).state).toBe("open");
      // the twin's own stop ends the device's move: the goTo answers that it did not get there
      const going = invoke(device, "goTo", { x: 160, y: 0, z: 80 }, auth);
      await waitState(s.things[0]!.tdUrl, "moving", 30_000, auth);
      expect((await invoke(s.things[0]!.tdUrl, "stop", "", auth)).body.stopped).toBe(true);
      const stopped = await going;
      expect(stopped.status).toBe(409);
      expect(stopped.body.code).toBe("E_NOT_REACHED");
      expect(stopped.body.details.status).toBe("stopped");
    } finally {
      await s.stop();
    }
  });
});
