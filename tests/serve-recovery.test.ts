/**
 * End to end: the backend process is killed mid-motion; the servient answers 503 while it is down,
 * relaunches it, reloads robot and scene (including run-time edits), restores the last joint state and
 * keeps serving.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, waitMoved, waitState } from "./serve-helpers.js";

let s: RunningServient;
let base: string;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  base = `${s.url}/${s.things[0]!.slug}`;
});
afterAll(async () => s?.stop());

it("recovers from a backend killed mid-motion", async () => {
  expect((await invoke(base, "addObstacle", { name: "post", shape: { type: "cylinder", radius: 0.05, length: 1 }, position: [0.5, 0.5, 0.5] })).status).toBe(200);
  const blocked = kukaPose([0.785, 1.2, 0, -0.3, 0, 0.4, 0]);
  expect((await invoke(base, "validateJointPosition", { joints: blocked })).body.valid).toBe(false);

  const move = invoke(base, "moveToJointPosition", { joints: kukaPose([-1.5, 0.4, 0, -0.8, 0, 0.4, 0]), speed: 0.05 });
  await waitState(base, "moving");
  await waitMoved(base, "lbr_iiwa_joint_1", 0);
  const pid = s.backend.pid;
  expect(pid).toBeTypeOf("number");
  process.kill(pid!, "SIGKILL");
  const r = await move;
  expect(r.status).toBe(503);
  expect(r.body.code).toBe("E_BACKEND_DOWN");
  const lastSeen = (await http(`${base}/properties/getJointPosition`)).body;
  expect(lastSeen.lbr_iiwa_joint_1).toBeLessThan(-0.01);

  const during = await invoke(base, "validateJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) });
  expect([200, 503]).toContain(during.status);

  await s.backend.waitUp(60_000);
  expect(s.backend.pid).not.toBe(pid);
  expect(s.backend.restarts).toBe(1);
  const restored = (await http(`${base}/properties/getJointPosition`)).body;
  for (const [k, v] of Object.entries(lastSeen)) expect(restored[k]).toBeCloseTo(v as number, 3);
  const status = (await http(`${base}/properties/motionStatus`)).body;
  expect(status.lastError.code).toBe("E_BACKEND_RESTARTED");
  // the run-time obstacle is back in the world
  expect((await invoke(base, "validateJointPosition", { joints: blocked })).body.valid).toBe(false);
  const again = await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0.3, 0, -0.6, 0, 0.3, 0]) });
  expect(again.status).toBe(200);
  expect(again.body.status).toBe("reached");
});
