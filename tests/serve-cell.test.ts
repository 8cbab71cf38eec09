/**
 * End to end: a twin generated with a conveyor scene (examples/scenes/conveyor.json: a belt carrying a red
 * cube past a colour sensor towards an infrared beam) keeps the belt and the sensors in its scene.json;
 * `serve` serves each of them as a Thing of its own beside the twin (`/belt`, `/beam`, `/eye`), listed by
 * the directory. Over real HTTP the belt starts, the cube passes the colour sensor and reaches the beam,
 * the belt stops; a node-wot consumer starts the belt from its TD; a restarted backend gets the running
 * belt back from the servient's record.
 */
import { cpSync, readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO } from "./cli-run.js";
import { validateThingDescription } from "@robwot/core";
import { openSse } from "./helpers/sse.js";
import { consumer, generateTwin, http, invoke, live, sleep, waitFor } from "./serve-helpers.js";
import { officialTdValidation } from "./twin-files.js";

let s: RunningServient;
let dir: string;
let twin: string;
const at = (path: string): string => `${s.url}/${path}`;

beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000, ["--scene", join(REPO, "examples", "scenes", "conveyor.json")]);
  // twice the wall clock: the cube's 0.6 m on the belt take ~6 s
  s = await startServient({ twins: [dir], port: 0, realtime: 2 });
  twin = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

const cubeY = async (): Promise<number> => ((await http(`${twin}/properties/objects`)).body as { name: string; position: number[] }[]).find((o) => o.name === "cube")!.position[1]!;

it("keeps the scene's conveyors and sensors in the twin's scene.json", () => {
  const scene = JSON.parse(readFileSync(join(dir, "scene.json"), "utf8"));
  expect(scene.conveyors.map((c: { name: string }) => c.name)).toEqual(["belt"]);
  expect(scene.conveyors[0]).toMatchObject({ state: "stopped", speed: 0.05, endStop: true });
  expect(scene.sensors.map((c: { name: string; kind: string }) => [c.name, c.kind])).toEqual([
    ["beam", "presence"],
    ["eye", "color"],
  ]);
  expect(scene.sensors[0].reading).toBeUndefined();
});

it("serves each device's TD and lists it in the directory", async () => {
  const belt = await http(at("belt"));
  expect(belt.status).toBe(200);
  expect(belt.type).toContain("application/td+json");
  expect(Object.keys(belt.body.actions)).toEqual(["startBeltForward", "startBeltBackward", "stopBelt"]);
  expect(belt.body.properties.speed).toMatchObject({ unit: "m/s", readOnly: false, exclusiveMinimum: 0, maximum: 1 });
  expect(belt.body.properties.speed.forms[0].href).toBe(`${s.url}/belt/properties/speed`);
  expect(belt.body.securityDefinitions).toEqual({ nosec_sc: { scheme: "nosec" } });
  const beam = (await http(at("beam"))).body;
  expect(beam.properties.objectPresence.type).toBe("boolean");
  expect(Object.keys(beam.events)).toContain("detectedObject");
  expect(beam.events.detectedObject.data.properties.time.unit).toBe("s");
  const eye = (await http(at("eye"))).body;
  expect(eye.properties.color.oneOf.map((o: { type: string }) => o.type)).toEqual(["object", "null"]);
  const listed = (await http(`${s.url}/things`)).body as { id: string; title: string }[];
  const ids = listed.map((t) => t.id);
  for (const td of [belt.body, beam, eye]) expect(ids).toContain(td.id);
  expect(listed.map((t) => t.title)).toEqual(expect.arrayContaining(["belt", "beam", "eye"]));
  for (const td of [belt.body, beam, eye]) {
    expect((await validateThingDescription(td)).errors).toEqual([]);
    const { result } = await officialTdValidation(JSON.stringify(td));
    expect(result.report.schema).toBe("passed");
  }
});

it("starts the belt, carries the cube past the colour sensor to the beam, and stops it", async () => {
  expect((await http(at("belt/properties/state"))).body).toBe("stopped");
  expect((await http(at("beam/properties/objectPresence"))).body).toBe(false);
  expect((await http(at("eye/properties/color"))).body).toBeNull();
  const y0 = await cubeY();
  // the beam's event, over SSE and over node-wot's long poll (subscribed before the belt starts)
  const sse = await openSse(at("beam/events/detectedObject/sse"));
  const c = await consumer();
  const heard: unknown[] = [];
  const beam = await c.wot.consume(await c.wot.requestThingDescription(at("beam")));
  const sub = await beam.subscribeEvent("detectedObject", async (out) => void heard.push(await out.value()));
  const ws = await live(`${s.liveUrl}?thing=${s.things[0]!.slug}`);
  const started = await invoke(at("belt"), "startBeltForward", "");
  expect(started.status).toBe(200);
  expect(started.body).toEqual({ state: "forward", speed: 0.05, changed: true });
  // starting a running belt again: its state, nothing changed
  const again = await invoke(at("belt"), "startBeltForward", "");
  expect(again.status).toBe(200);
  expect(again.body).toEqual({ state: "forward", speed: 0.05, changed: false });
  const color = await waitFor(async () => (await http(at("eye/properties/color"))).body, { timeoutMs: 60_000, intervalMs: 20, what: "the eye seeing the cube" });
  expect(color.r).toBeGreaterThan(200);
  expect(color.g).toBeLessThan(50);
  expect(color.b).toBeLessThan(50);
  await waitFor(async () => (await http(at("beam/properties/objectPresence"))).body === true, { timeoutMs: 60_000, intervalMs: 20, what: "the beam seeing the cube" });
  const stopped = await invoke(at("belt"), "stopBelt", "");
  expect(stopped.body).toMatchObject({ state: "stopped", changed: true });
  try {
    await sse.wait((m) => m.some((x) => x.event === "detectedObject"), 30_000);
    await waitFor(() => heard.length > 0, { what: "node-wot hearing detectedObject" });
  } finally {
    sse.close();
    await sub.stop().catch(() => undefined);
    await c.stop();
  }
  const event = sse.events().find((e) => e.event === "detectedObject")!.data;
  expect(event.object).toBe("cube");
  expect(event.time).toBeGreaterThan(0);
  expect(heard[0]).toEqual(event);
  // the twin's objects property and its /live scene messages followed the cube along the belt (+y)
  const y1 = await cubeY();
  expect(y1).toBeGreaterThan(y0 + 0.5);
  const cubeAt = (m: { objects: { name: string; position: number[] }[] }): number => m.objects.find((o) => o.name === "cube")!.position[1]!;
  const scene = await ws.waitFor((m) => m.type === "scene" && cubeAt(m) > y0 + 0.5);
  ws.close();
  // the belt comes with the scene (the viewer draws it)
  expect(scene.conveyors.map((c: { name: string }) => c.name)).toEqual(["belt"]);
  expect(scene.obstacles.map((o: { name: string }) => o.name)).not.toContain("belt");
  // a stopped belt moves nothing: a gap of several clock ticks
  await sleep(300);
  expect(await cubeY()).toBe(y1);
});

it("refuses a twin folder whose scene.json has a conveyor or sensor that is not an object with a name", async () => {
  const bad = `${dir}-bad`;
  cpSync(dir, bad, { recursive: true });
  const scene = JSON.parse(readFileSync(join(bad, "scene.json"), "utf8"));
  writeFileSync(join(bad, "scene.json"), JSON.stringify({ ...scene, sensors: [...scene.sensors, 5] }));
  await expect(startServient({ twins: [bad], port: 0 })).rejects.toMatchObject({ code: "E_TWIN_FOLDER", message: expect.stringContaining("sensors[2]") });
  writeFileSync(join(bad, "scene.json"), JSON.stringify({ ...scene, conveyors: { belt: {} } }));
  await expect(startServient({ twins: [bad], port: 0 })).rejects.toMatchObject({ code: "E_TWIN_FOLDER", message: expect.stringContaining("conveyors must be an array") });
});

it("answers unknown affordances and bad bodies with problem details 4xx", async () => {
  const unknown = await invoke(at("belt"), "jump", {});
  expect(unknown.status).toBe(404);
  expect(unknown.type).toContain("application/problem+json");
  expect((await http(at("beam/properties/speed"))).status).toBe(404);
  const notJson = await http(at("belt/actions/stopBelt"), { method: "POST", headers: { "content-type": "text/plain" }, body: "go" });
  expect(notJson.status).toBe(415);
  const put = (property: string, body: string): Promise<{ status: number; type: string | null }> => http(at(`belt/properties/${property}`), { method: "PUT", headers: { "content-type": "application/json" }, body });
  expect((await put("state", '"forward"')).status).toBe(405);
  for (const bad of ["2", "0", '"fast"', "{"]) {
    const r = await put("speed", bad);
    expect(r.status).toBe(400);
    expect(r.type).toContain("application/problem+json");
  }
  expect((await put("speed", "0.1")).status).toBe(204);
  expect((await http(at("belt/properties/speed"))).body).toBe(0.1);
  expect((await http(at("belt/properties/state"))).body).toBe("stopped");
  expect((await put("speed", "0.05")).status).toBe(204);
  expect((await http(at("belt/robot.urdf"))).status).toBe(404);
});

it("a node-wot consumer starts the belt from its TD", async () => {
  const c = await consumer();
  try {
    const td = await c.wot.requestThingDescription(at("belt"));
    const belt = await c.wot.consume(td);
    const out = await (await belt.invokeAction("startBeltForward")).value();
    expect(out).toMatchObject({ state: "forward", changed: true });
    expect(await (await belt.readProperty("state")).value()).toBe("forward");
  } finally {
    await c.stop();
  }
  // a restarted backend has the belt back running (the servient's record), the cube where it was
  const y = await cubeY();
  const restarts = s.backend.restarts;
  process.kill(s.backend.pid!, "SIGKILL");
  await waitFor(() => s.backend.restarts > restarts && s.backend.isUp, { timeoutMs: 120_000, what: "the backend restarted" });
  const cell = await s.backend.sim.listCell();
  expect(cell.conveyors[0]).toMatchObject({ name: "belt", state: "forward" });
  expect(Math.abs((await cubeY()) - y)).toBeLessThan(0.1);
  expect((await invoke(at("belt"), "stopBelt", "")).body).toMatchObject({ state: "stopped" });
});
