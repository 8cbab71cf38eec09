/**
 * Hostile values never become state: absurd or non-fitting calibrations answer 400 and save nothing, a
 * calibration.json with absurd values is refused at load naming the file, and every number the TD's
 * schemas allow is handled (no 500). Real servient, real backend, real HTTP.
 */
import { existsSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import AjvModule from "ajv";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, live } from "./serve-helpers.js";

let s: RunningServient;
const Ajv = AjvModule.default;
let base: string;
let dir: string;

beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
  s = await startServient({ twins: [dir], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

const P = [
  [0.1, 0.2, 0.3],
  [0.5, -0.1, 0.4],
  [-0.3, 0.4, 0.2],
  [0.2, 0.1, 0.9],
];
const xyz = (v: number[]): { x: number; y: number; z: number } => ({ x: v[0]!, y: v[1]!, z: v[2]! });

describe("calibrate refuses what is not a calibration, and saves nothing", () => {
  it.each([
    ["real points of 1e308", P.map((v) => ({ real: xyz(v.map((c) => c * 1e308)), virtual: xyz(v) })), "E_BAD_INPUT", /real\/x must be <= 1000/],
    ["real points in millimetres (scale 1000)", P.map((v) => ({ real: xyz(v.map((c) => c * 1000)), virtual: xyz(v) })), "E_CALIBRATION", /scale .* outside/],
    ["pairs in the wrong order (rms of metres)", P.map((v, i) => ({ real: xyz(P[(i + 1) % 4]!.map((c) => c * 3)), virtual: xyz(v) })), "E_CALIBRATION", /RMS residual|scale/],
  ])("%s: 400, no calibration.json, TD bounds unchanged", async (_what, pairs, code, message) => {
    const tdBefore = (await http(base)).body;
    const r = await invoke(base, "calibrate", { pairs });
    expect(r.status).toBe(400);
    expect(r.body.code).toBe(code);
    expect(r.body.message).toMatch(message);
    expect(existsSync(join(dir, "calibration.json"))).toBe(false);
    expect((await http(`${base}/properties/calibration`)).body).toEqual({ active: false });
    expect((await http(base)).body.actions.moveToCartesianPosition.input).toEqual(tdBefore.actions.moveToCartesianPosition.input);
  });
});

describe("numbers the schema allows are handled", () => {
  it("a speed of 1e-300 is refused by the schema (400), the documented minimum 0.001 works", async () => {
    const joints = kukaPose([0.1, 0, 0, 0, 0, 0, 0]);
    const tiny = await invoke(base, "validateJointPosition", { joints, speed: 1e-300 });
    expect(tiny.status).toBe(400);
    expect((await http(base)).body.actions.moveToJointPosition.input.properties.speed.minimum).toBe(0.001);
    const slow = await invoke(base, "validateJointPosition", { joints, speed: 0.001 });
    expect(slow.status).toBe(200);
    expect(slow.body.valid).toBe(true);
  });
});

describe("obstacle numbers: the TD states the range the backend accepts", () => {
  it("addObstacle and moveObstacle bound positions, angles and sizes to 1e4; calibrate bounds points to 1000 m", async () => {
    const { actions } = (await http(base)).body;
    const add = actions.addObstacle.input.properties;
    expect(add.position.items).toMatchObject({ minimum: -1e4, maximum: 1e4 });
    expect(add.rpy.items).toMatchObject({ minimum: -1e4, maximum: 1e4 });
    expect(actions.moveObstacle.input.properties.position.items).toMatchObject({ minimum: -1e4, maximum: 1e4 });
    const box = add.shape.oneOf.find((o: { properties: { type: { const: string } } }) => o.properties.type.const === "box");
    expect(box.properties.size.items).toMatchObject({ exclusiveMinimum: 0, maximum: 1e4 });
    const pair = actions.calibrate.input.properties.pairs.items.properties;
    expect(pair.real.properties.x).toMatchObject({ minimum: -1000, maximum: 1000 });
  });

  it("the TD's obstacle inputs accept exactly what the servient accepts (closed objects, orientation xor rpy)", async () => {
    const { actions } = (await http(base)).body;
    const ajv = new Ajv({ strict: false });
    const box = { type: "box", size: [0.1, 0.1, 0.1] };
    const cases: [string, Record<string, unknown>][] = [
      ["plain", { name: "x1", shape: box, position: [3, 0, 0] }],
      ["orientation", { name: "x2", shape: box, position: [3, 1, 0], orientation: [0, 0, 0, 1] }],
      ["rpy", { name: "x3", shape: box, position: [3, 2, 0], rpy: [0, 0, 1] }],
      ["both", { name: "x4", shape: box, position: [3, 3, 0], orientation: [0, 0, 0, 1], rpy: [0, 0, 1] }],
      ["extra property", { name: "x5", shape: box, position: [3, 4, 0], mass: 2 }],
      ["extra shape field", { name: "x6", shape: { ...box, radius: 1 }, position: [3, 5, 0] }],
      ["colour", { name: "x7", shape: { type: "sphere", radius: 0.05 }, position: [3, 6, 0], color: [1, 0, 0] }],
    ];
    expect(actions.addObstacle.input.additionalProperties).toBe(false);
    const accepts = ajv.compile(actions.addObstacle.input);
    // every error answer has the body the forms declare (additionalResponses -> schemaDefinitions.error)
    const td = (await http(base)).body;
    expect(actions.addObstacle.forms[0].additionalResponses[0]).toMatchObject({ success: false, schema: "error" });
    const errorBody = ajv.compile(td.schemaDefinitions.error);
    for (const [label, body] of cases) {
      const r = await invoke(base, "addObstacle", body);
      expect([label, r.status === 200], JSON.stringify(r.body)).toEqual([label, accepts(body)]);
      if (r.status !== 200) expect(errorBody(r.body), JSON.stringify(r.body)).toBe(true);
    }
    expect(accepts(cases[3]![1])).toBe(false);
    const moves = ajv.compile(actions.moveObstacle.input);
    for (const body of [{ name: "x1", position: [3, 0, 1], rpy: [0, 0, 1] }, { name: "x1", position: [3, 0, 1], rpy: [0, 0, 1], orientation: [0, 0, 0, 1] }]) {
      expect((await invoke(base, "moveObstacle", body)).status === 200).toBe(moves(body));
    }
    for (const n of ["x1", "x2", "x3", "x7"]) expect((await invoke(base, "removeObstacle", { name: n })).status).toBe(200);
  });

  it("moveObstacle to 1e308 m: 400, the obstacle stays where it was", async () => {
    const box = { name: "far", shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [2, 0, 0] };
    expect((await invoke(base, "addObstacle", box)).status).toBe(200);
    const r = await invoke(base, "moveObstacle", { name: "far", position: [1e308, 0, 0] });
    expect(r.status).toBe(400);
    expect(JSON.stringify(r.body)).toMatch(/position/);
    const c = await live(s.liveUrl);
    c.ws.send(JSON.stringify({ subscribe: s.things[0]!.slug }));
    const scene = await c.waitFor((m) => m.type === "scene");
    c.close();
    expect(scene.obstacles.find((o: { name: string }) => o.name === "far").position).toEqual([2, 0, 0]);
    expect((await invoke(base, "removeObstacle", { name: "far" })).status).toBe(200);
  });
});

describe("the realtime option", () => {
  it("a factor the backend refuses (0.001) stops startServient, instead of a 400 on every move", async () => {
    const err = await startServient({ twins: [dir], port: 0, realtime: 0.001 }).then(
      async (other) => {
        await other.stop();
        return null;
      },
      (e: unknown) => e as Error,
    );
    expect(err?.message).toMatch(/realtime must be 0 \(as fast as possible\) or in \[0\.01, 1000\], got 0\.001/);
  });
});

describe("calibration.json is checked at load", () => {
  it.each([
    ["a scale of 1e400 (Infinity)", '{"scale": 1e400, "rotation": [[1,0,0],[0,1,0],[0,0,1]], "translation": [0,0,0]}', /scale/],
    ["a rotation that is not one", '{"scale": 1, "rotation": [[2,0,0],[0,1,0],[0,0,1]], "translation": [0,0,0]}', /rotation/],
    ["a translation of 1e9 m", '{"scale": 1, "rotation": [[1,0,0],[0,1,0],[0,0,1]], "translation": [1e9,0,0]}', /translation/],
  ])("%s: serve refuses the folder naming the file", async (_what, text, message) => {
    const bad = await generateTwin("kuka_iiwa", 3000);
    writeFileSync(join(bad, "calibration.json"), text);
    const err = await startServient({ twins: [bad], port: 0 }).then(
      async (other) => {
        await other.stop();
        return null;
      },
      (e: unknown) => e as Error,
    );
    expect(err?.message).toContain(join(bad, "calibration.json"));
    expect(err?.message).toMatch(message);
  });
});
