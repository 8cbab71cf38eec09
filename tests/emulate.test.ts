/**
 * `robwot emulate`: the stand-in physical robot. Its moves reach their targets within its own limits, a jog
 * moves a joint at its velocity and a stop ends it, a joint reaching its limit is a protective stop, the
 * reported joints lag the true ones by the configured time constant, and a twin served with --follow at
 * its TD mirrors it. Real emulator (its own backend), real servient, real HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulator, startServient, type RunningEmulator, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, live, sleep } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
let robot: RunningEmulator;
let lagged: RunningEmulator;
let twin: RunningServient;

beforeAll(async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  [robot, lagged] = await Promise.all([
    startEmulator({ folder: dir, port: 0, latencyMs: 20 }),
    startEmulator({ folder: dir, port: 0, lag: 0.2, velocityScale: 0.5 }),
  ]);
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: robot.tdUrl, followRate: 50 });
});
afterAll(async () => {
  await twin?.stop();
  await Promise.all([robot?.stop(), lagged?.stop()]);
});

const joints = async (td: string): Promise<Record<string, number>> => (await http(`${td}/properties/getJointPosition`)).body;

it("serves a TD with the twin's names and jog; a joint move reaches its target", async () => {
  const td = (await http(robot.tdUrl)).body;
  expect(Object.keys(td.actions).sort()).toEqual(["jog", "moveToCartesianPosition", "moveToJointPosition", "stop"]);
  expect(td.title).toMatch(/-emulated$/);
  expect(robot.tdUrl).toMatch(/\/lbr_iiwa-emulated$/);
  const target = kukaPose([0.4, 0.3, 0, -0.6, 0, 0.4, 0]);
  const r = await invoke(robot.tdUrl, "moveToJointPosition", { joints: target, speed: 0.5 });
  expect(r.status, JSON.stringify(r.body)).toBe(200);
  expect(r.body.status).toBe("reached");
  const q = await joints(robot.tdUrl);
  for (const [j, v] of Object.entries(target)) expect(q[j]).toBeCloseTo(v, 9);
  // a Cartesian move by the controller's own IK: the pose of another configuration
  expect((await invoke(robot.tdUrl, "moveToCartesianPosition", { x: 0.45, y: 0.1, z: 0.55, speed: 0.5 })).body.status).toBe("reached");
});

it("a jog moves the joint at its velocity until its time is up, a stop ends it at once, a limit is a protective stop", async () => {
  const from = (await joints(robot.tdUrl))[J1]!;
  const jog = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 0.5 }, duration: 0.4 });
  expect(jog.body.status).toBe("reached");
  expect((await joints(robot.tdUrl))[J1]! - from).toBeCloseTo(0.2, 1);
  const long = invoke(robot.tdUrl, "jog", { velocities: { [J1]: -0.3 }, duration: 20 });
  await sleep(300);
  expect((await invoke(robot.tdUrl, "stop", "")).body).toEqual({ stopped: true });
  expect((await long).body.status).toBe("stopped");
  const held = (await joints(robot.tdUrl))[J1]!;
  await sleep(200);
  expect((await joints(robot.tdUrl))[J1]).toBe(held);
  // toward the limit (2.96 rad) at its velocity limit: a protective stop at the limit
  const hit = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 10 }, duration: 5 });
  expect(hit.body.status).toBe("stopped");
  const status = (await http(`${robot.tdUrl}/properties/motionStatus`)).body;
  expect(status.state).toBe("stopped");
  expect(status.lastError.message).toMatch(/^protective stop: joint lbr_iiwa_joint_1 reached its limit/);
});

it("reports its joints lagging by the time constant: v x lag behind at a constant velocity", async () => {
  // 0.5 rad/s for 1.5 s: after the first-order lag has settled (> 5 x 0.2 s), the report is 0.5 x 0.2 = 0.1 rad behind
  const from = (await joints(lagged.tdUrl))[J1]!;
  const t0 = performance.now();
  const jog = invoke(lagged.tdUrl, "jog", { velocities: { [J1]: 0.5 }, duration: 1.5 });
  await sleep(1_300);
  const before = (performance.now() - t0) / 1000;
  const seen = (await joints(lagged.tdUrl))[J1]! - from;
  const after = (performance.now() - t0) / 1000;
  await jog;
  // read between `before` and `after`, the jog started a few ms after t0: the true position was at most
  // 0.5 x after and at least 0.5 x (before - 0.03); the report 0.1 rad behind it, +-10 %
  expect(seen).toBeLessThanOrEqual(0.5 * after - 0.09);
  expect(seen).toBeGreaterThanOrEqual(0.5 * (before - 0.03) - 0.11);
});

it("a twin following the emulated robot mirrors its jog", async () => {
  const target = (await joints(robot.tdUrl))[J1]! - 0.3;
  await invoke(robot.tdUrl, "jog", { velocities: { [J1]: -0.6 }, duration: 0.5 });
  const end = Date.now() + 10_000;
  for (;;) {
    const s = (await http(`${twin.things[0]!.tdUrl}/properties/physicalState`)).body;
    const q = await joints(twin.things[0]!.tdUrl);
    if (Math.abs(q[J1]! - target) < 0.02 && s.followed > 0) break;
    if (Date.now() > end) throw new Error(`the twin did not follow: ${JSON.stringify(s)}`);
    await sleep(50);
  }
});

it("a relayed move is compared with the physical robot's: a robot lagging 0.2 s at 0.5 rad/s diverges by 0.1 rad (+-10 %), and the event says so", async () => {
  // a twin that relays to an emulated robot lagging 0.2 s, and so follows it (no --follow needed); the
  // simulation runs at once, the robot after it
  const slow = await startEmulator({ folder: await generateTwin("kuka_iiwa", 3000), port: 0, lag: 0.2 });
  const relaying = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: slow.tdUrl, followRate: 50 });
  try {
    const base = relaying.things[0]!.tdUrl;
    const stream = await live(`${relaying.liveUrl}?thing=${relaying.things[0]!.slug}`);
    // 1 rad of joint 1 at 5 % of 10 rad/s = 0.5 rad/s, in the simulation and then on the robot
    const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([-1, 0, 0, 0, 0, 0, 0]), speed: 0.05 });
    expect(r.body.relay.ok, JSON.stringify(r.body.relay)).toBe(true);
    const s = (await http(`${base}/properties/physicalState`)).body;
    expect(s.maxDivergence.joint).toBeGreaterThan(0.09);
    expect(s.maxDivergence.joint).toBeLessThan(0.115);
    expect(s.maxDivergence.bound).toBe(0.05);
    const event = await stream.waitFor((m) => m.type === "divergence", 3_000).catch(() => {
      throw new Error(`no divergence message among ${JSON.stringify([...new Set(stream.messages.map((m) => m.type))])}: ${JSON.stringify(s)}`);
    });
    stream.close();
    expect(stream.messages.filter((m) => m.type === "divergence")).toHaveLength(1);
    expect(event.joint).toBeGreaterThan(0.05);
    expect(event.bound).toBe(0.05);
    expect(stream.messages.some((m) => m.type === "physical" && m.following)).toBe(true);
  } finally {
    await relaying.stop();
    await slow.stop();
  }
});

