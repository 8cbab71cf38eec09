/**
 * `robwot emulate`: the stand-in physical robot. Its moves reach their targets within its own limits, a jog
 * moves a joint at its velocity and a stop ends it, a joint reaching its limit is a protective stop, the
 * reported joints lag the true ones by the configured time constant, and a twin served with --follow at
 * its TD mirrors it. Real emulator (its own backend), real servient, real HTTP. Lags are long (0.5 s) so
 * that a loaded machine's late ticks and requests stay small beside what is measured.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulator, startServient, type RunningEmulator, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, live, waitFor, waitMoved, waitSettled } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
let robot: RunningEmulator;
let lagged: RunningEmulator;
let twin: RunningServient;

beforeAll(async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  [robot, lagged] = await Promise.all([
    startEmulator({ folder: dir, port: 0, latencyMs: 20 }),
    startEmulator({ folder: dir, port: 0, lag: 0.5, velocityScale: 0.5 }),
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
  const start = (await joints(robot.tdUrl))[J1]!;
  const long = invoke(robot.tdUrl, "jog", { velocities: { [J1]: -0.3 }, duration: 20 });
  await waitMoved(robot.tdUrl, J1, start);
  expect((await invoke(robot.tdUrl, "stop", "")).body).toEqual({ stopped: true });
  expect((await long).body.status).toBe("stopped");
  const held = (await joints(robot.tdUrl))[J1]!;
  // a still jog runs on the controller's clock after the stop: it is accepted (nothing runs on) and ends
  // where the stop left the joint
  const still = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 0 }, duration: 0.1 });
  expect(still.body.status, JSON.stringify(still.body)).toBe("reached");
  expect((await joints(robot.tdUrl))[J1]).toBe(held);
  // toward the limit (2.96 rad) at its velocity limit: a protective stop at the limit
  const hit = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 10 }, duration: 5 });
  expect(hit.body.status).toBe("stopped");
  const status = (await http(`${robot.tdUrl}/properties/motionStatus`)).body;
  expect(status.state).toBe("stopped");
  expect(status.lastError.message).toMatch(/^protective stop: joint lbr_iiwa_joint_1 reached its limit/);
});

it("reports its joints lagging by the time constant: v x lag behind at a constant velocity", async () => {
  // 0.5 rad/s for 3 s (6 time constants: the lag has settled). The jog's answer carries the report as the
  // jog ends, 0.5 x 0.5 = 0.25 rad behind the true joint; the report then settles where the joint stopped.
  // Stepped on the controller's clock, a first-order lag trails at most v x lag, less by a few ticks' worth.
  const jog = await invoke(lagged.tdUrl, "jog", { velocities: { [J1]: 0.5 }, duration: 3 });
  expect(jog.body.status).toBe("reached");
  const behind = (await waitSettled(lagged.tdUrl, 1e-5))[J1]! - jog.body.joints[J1];
  expect(behind).toBeLessThanOrEqual(0.25 + 1e-9);
  expect(behind).toBeGreaterThanOrEqual(0.9 * 0.25);
});

it("a twin following the emulated robot mirrors its jog", async () => {
  const target = (await joints(robot.tdUrl))[J1]! - 0.3;
  await invoke(robot.tdUrl, "jog", { velocities: { [J1]: -0.6 }, duration: 0.5 });
  await waitFor(
    async () => {
      const state = (await http(`${twin.things[0]!.tdUrl}/properties/physicalState`)).body;
      return Math.abs((await joints(twin.things[0]!.tdUrl))[J1]! - target) < 0.02 && state.followed > 0;
    },
    { what: "the twin following the jog" },
  );
});

it("a relayed move is compared with the physical robot's: a robot lagging 0.5 s at 0.5 rad/s diverges by 0.25 rad (-10 %, +15 %), and the event says so", async () => {
  // a twin that relays to an emulated robot lagging 0.5 s, and so follows it (no --follow needed); the
  // simulation runs at once, the robot after it. A reading is compared when it arrives, so its travel time
  // adds to the lag: the long lag keeps a loaded machine's slow requests small beside it.
  const slow = await startEmulator({ folder: await generateTwin("kuka_iiwa", 3000), port: 0, lag: 0.5 });
  const relaying = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: slow.tdUrl, followRate: 50 });
  try {
    const base = relaying.things[0]!.tdUrl;
    const stream = await live(`${relaying.liveUrl}?thing=${relaying.things[0]!.slug}`);
    // 1.6 rad of joint 1 at 5 % of 10 rad/s = 0.5 rad/s (3 s, 6 time constants), in the simulation and
    // then on the robot
    const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([-1.6, 0, 0, 0, 0, 0, 0]), speed: 0.05 });
    expect(r.body.relay.ok, JSON.stringify(r.body.relay)).toBe(true);
    const s = (await http(`${base}/properties/physicalState`)).body;
    expect(s.maxDivergence.joint).toBeGreaterThan(0.9 * 0.25);
    expect(s.maxDivergence.joint).toBeLessThan(1.15 * 0.25);
    expect(s.maxDivergence.bound).toBe(0.05);
    const event = await stream.waitFor((m) => m.type === "divergence").catch(() => {
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

