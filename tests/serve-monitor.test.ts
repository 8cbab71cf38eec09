/**
 * The safety monitor of `--follow`: an emulated robot (`robwot emulate`, which does not know the scene) is
 * jogged through its own Thing, as a pendant would, toward a box only the twin's scene has. In every one of
 * 20 approaches at speeds from 0.2 to 2 rad/s the twin emits `collisionImminent` naming the box and the
 * emulated robot stops before it touches (its final joints checked by the twin's backend); 20 jogs away
 * from the box at the same speeds are never stopped. Real emulator, servient, backends and HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulator, startServient, type RunningEmulator, type RunningServient } from "../packages/servient/src/index.js";
import { boxOnJoint1Arc, generateTwin, http, invoke, kukaPose, live, sleep, waitJoints, type LiveClient } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
const START = kukaPose([0, 1.0, 0, -1.0, 0, 0.5, 0]);
const SPEEDS = Array.from({ length: 20 }, (_, i) => 0.2 + (1.8 * i) / 19);

let robot: RunningEmulator;
let twin: RunningServient;
let base: string;
let stream: LiveClient;

beforeAll(async () => {
  robot = await startEmulator({ folder: await generateTwin("kuka_iiwa", 3000), port: 0 });
  // to START before the twin watches: the long first move is not what this file tests, and on a loaded
  // machine the monitor's extrapolation of it (the robot's deceleration unknown to it) may stop it
  expect((await invoke(robot.tdUrl, "moveToJointPosition", { joints: START })).body.status).toBe("reached");
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: robot.tdUrl, followRate: 50 });
  base = twin.things[0]!.tdUrl;
  stream = await live(`${twin.liveUrl}?thing=${twin.things[0]!.slug}`);
  // the twin follows the robot to START; the box is where the tool will be after 0.6 rad of joint 1
  await atStart();
  await boxOnJoint1Arc(base, 0.6, 0.12);
}, 120_000);

afterAll(async () => {
  stream?.close();
  await twin?.stop();
  await robot?.stop();
});

/** Until the twin (following the robot) stands at START. */
const atStart = (): Promise<void> => waitJoints(base, START);

const imminent = (): any[] => stream.messages.filter((m) => m.type === "collisionImminent");

it("stops every approach toward the box only the twin knows, before contact; never a clear jog", async () => {
  const sim = twin.backend.sim;
  const robotId = twin.twins.get(twin.things[0]!.slug)!.robotId;
  for (const [k, v] of SPEEDS.entries()) {
    expect((await invoke(robot.tdUrl, "moveToJointPosition", { joints: START })).body.status).toBe("reached");
    await atStart();
    await sleep(60); // and seen it stand still
    const before = imminent().length;
    const jog = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: v }, duration: 3 / v });
    expect(jog.body.status, `approach ${k} at ${v.toFixed(2)} rad/s ran its whole jog`).toBe("stopped");
    // the event follows the stop's answer from the robot, which may come after the jog's
    await stream.waitFor(() => imminent().length > before, 10_000);
    const events = imminent().slice(before);
    expect(events.length, `approach ${k}`).toBe(1);
    expect(events[0].stopped).toBe(true);
    expect(events[0].contacts.some((c: any) => c.a.body === "fixture" || c.b.body === "fixture")).toBe(true);
    const q = (await http(`${robot.tdUrl}/properties/getJointPosition`)).body as Record<string, number>;
    const check = await sim.checkCollision({ robot: robotId, positions: Object.values(q) });
    expect(check.collisionFree, `approach ${k} at ${v.toFixed(2)} rad/s touched: ${JSON.stringify(check.contacts)}`).toBe(true);
  }
  for (const [k, v] of SPEEDS.entries()) {
    // back at 0.5 rad/s: at full speed (10 rad/s) the monitor, extrapolating 0.2 s ahead, would rightly stop
    // a move that ends 0.45 rad short of the box
    const back = await invoke(robot.tdUrl, "moveToJointPosition", { joints: START, speed: 0.05 });
    expect(back.body.status, `back to START before clear jog ${k}: ${JSON.stringify(imminent().slice(-2))}`).toBe("reached");
    await atStart();
    await sleep(60);
    const before = imminent().length;
    const jog = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: -v }, duration: 0.3 });
    expect(jog.body.status, `clear jog ${k} at ${v.toFixed(2)} rad/s was stopped`).toBe("reached");
    expect(imminent().length).toBe(before);
  }
  const state = (await http(`${base}/properties/physicalState`)).body;
  expect(state.collisionImminent).toBe(SPEEDS.length);
}, 300_000);
