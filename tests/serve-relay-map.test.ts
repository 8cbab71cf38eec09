/**
 * `--relay-map`: a physical robot whose Thing does not use the twin's names, shaped like a UR's (a joint
 * array `actual_q` in degrees, `movej {q, v}`, `stopj`), served by a small node-wot stand-in in this test.
 * The twin relays its validated joint moves as `movej` in degrees, reads `actual_q` into `physicalState` in
 * radians, stops it with `stopj`, refuses a Cartesian command the map has no action for, and a bad map is
 * refused at start naming the file and the field. Real servient, backend and HTTP.
 */
import { mkdtempSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, KUKA_JOINTS, kukaPose, sleep, waitFor } from "./serve-helpers.js";

const require = createRequire(import.meta.url);
const { Servient } = require("@node-wot/core") as typeof import("@node-wot/core");
const { HttpServer } = require("@node-wot/binding-http") as typeof import("@node-wot/binding-http");

/** The stand-in: its joints (degrees, in the map's order) and the commands it received. */
const robot = { q: [0, 0, 0, 0, 0, 0, 0], calls: [] as { action: string; input: unknown }[] };
let standIn: InstanceType<typeof Servient>;
let tdUrl: string;
let twin: RunningServient;
let base: string;
const dir = mkdtempSync(join(tmpdir(), "robwot-relay-map-"));
// the stand-in lists the joints from the wrist down: the map says so
const ORDER = [...KUKA_JOINTS].reverse();
const MAP = { joints: ORDER, unit: "deg", jointState: "actual_q", moveJoints: { action: "movej", joints: "q", speed: "v" }, stop: "stopj" };

beforeAll(async () => {
  standIn = new Servient();
  const server = new HttpServer({ port: 0, address: "127.0.0.1" });
  standIn.addServer(server);
  const wot = await standIn.start();
  (server as unknown as { baseUri: string }).baseUri = `http://127.0.0.1:${server.getPort()}`;
  const thing = await wot.produce({
    title: "ur-standin",
    properties: { actual_q: { type: "array", items: { type: "number" }, readOnly: true } },
    actions: {
      movej: { input: { type: "object", properties: { q: { type: "array", items: { type: "number" } }, v: { type: "number" } } } },
      stopj: {},
    },
  } as unknown as WoT.ExposedThingInit);
  thing.setPropertyReadHandler("actual_q", async () => robot.q);
  thing.setActionHandler("movej", async (i) => {
    const input = (await i.value()) as { q: number[]; v: number };
    robot.calls.push({ action: "movej", input });
    // a move takes the robot a while: the relay awaits its answer (no test here reads a time)
    await sleep(100);
    robot.q = [...input.q];
    return undefined;
  });
  thing.setActionHandler("stopj", async () => {
    robot.calls.push({ action: "stopj", input: null });
    return undefined;
  });
  await thing.expose();
  const href = String(thing.getThingDescription().properties?.["actual_q"]?.forms?.[0]?.href ?? "");
  tdUrl = href.replace(/\/properties\/.*$/, "");
  writeFileSync(join(dir, "ur.json"), JSON.stringify(MAP));
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: tdUrl, follow: tdUrl, relayMap: join(dir, "ur.json"), monitor: "off" });
  base = twin.things[0]!.tdUrl;
});
afterAll(async () => {
  await twin?.stop();
  await standIn?.shutdown();
});

it("relays a joint move as movej in degrees, in the map's joint order, and mirrors actual_q in radians", async () => {
  const target = kukaPose([0.5, 0.3, 0, -0.6, 0, 0.4, 0.2]);
  const r = await invoke(base, "moveToJointPosition", { joints: target, speed: 0.5 });
  expect(r.body.status).toBe("reached");
  expect(r.body.relay.ok, JSON.stringify(r.body.relay)).toBe(true);
  const call = robot.calls.find((c) => c.action === "movej")!;
  const q = (call.input as { q: number[]; v: number }).q;
  ORDER.forEach((j, i) => expect(q[i]).toBeCloseTo((target[j] as number) * (180 / Math.PI), 9));
  expect((call.input as { v: number }).v).toBe(0.5);
  const s = await waitFor(async () => {
    const v = (await http(`${base}/properties/physicalState`)).body;
    return v.joints && Math.abs(v.joints.lbr_iiwa_joint_1 - 0.5) < 1e-9 ? v : null;
  }, { what: "physicalState showing the move" });
  for (const [j, v] of Object.entries(target)) expect(s.joints[j]).toBeCloseTo(v as number, 9);
});

it("stops it with stopj, and refuses a Cartesian command the map has no action for", async () => {
  const stops = robot.calls.filter((c) => c.action === "stopj").length;
  expect((await invoke(base, "stop", "")).body.physical.ok).toBe(true);
  expect(robot.calls.filter((c) => c.action === "stopj").length).toBeGreaterThan(stops);
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  const r = await invoke(base, "moveToCartesianPosition", { x: p.x, y: p.y + 0.05, z: p.z });
  expect(r.body.status).toBe("reached");
  expect(r.body.relay.ok).toBe(false);
  expect(r.body.relay.error).toMatch(/the relay map names no Cartesian move \(moveCartesian\)/);
});

it("a bad map is refused at start naming the file and the field", async () => {
  const bad = join(dir, "bad.json");
  writeFileSync(bad, JSON.stringify({ ...MAP, joints: ORDER.slice(1) }));
  await expect(startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, relay: tdUrl, relayMap: bad })).rejects.toThrow(/bad\.json: joints: every joint of the twin exactly once \(missing: lbr_iiwa_joint_7\)/);
  writeFileSync(bad, JSON.stringify({ ...MAP, unit: "grad" }));
  await expect(startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, relay: tdUrl, relayMap: bad })).rejects.toThrow(/bad\.json: unit: "rad" or "deg", got "grad"/);
});
