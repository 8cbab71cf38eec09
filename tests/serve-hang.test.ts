/**
 * A backend that stops answering (SIGSTOP) is declared dead at the heartbeat's deadline: calls in flight answer
 * 503 JSON, motionStatus says what happened, the backend is killed and restarted with the recorded
 * state, and an operation that timed out is not applied behind the twin's back. Real servient, real
 * backend process, real HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, waitMoved } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";

let s: RunningServient;
let base: string;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  base = `${s.url}/${s.things[0]!.slug}`;
});
afterAll(async () => {
  const pid = s?.backend.pid;
  if (pid) {
    try {
      process.kill(pid, "SIGCONT");
    } catch {
      // already gone: nothing to resume
    }
  }
  await s?.stop();
});

// the heartbeat (dead after 5 s without an answer) ends a call in flight: without it the call would hang
// until the test's own timeout
it("a move in flight on a stopped backend answers 503 at the deadline; the backend is replaced", async () => {
  const from = (await http(`${base}/properties/getJointPosition`)).body[J1] as number;
  const move = invoke(base, "moveToJointPosition", { joints: kukaPose([-1.5, 0.4, 0, -0.8, 0, 0.4, 0]), speed: 0.05 });
  // the backend runs the motion (not still planning it)
  await waitMoved(base, J1, from);
  const pid = s.backend.pid!;
  process.kill(pid, "SIGSTOP");
  const r = await move;
  expect(r.status).toBe(503);
  expect(r.body.code).toBe("E_BACKEND_DOWN");
  const status = (await http(`${base}/properties/motionStatus`)).body;
  expect(status.state).toBe("stopped");
  expect(["E_BACKEND_DOWN", "E_BACKEND_RESTARTED"]).toContain(status.lastError.code);
  await s.backend.waitUp(60_000);
  expect(s.backend.pid).not.toBe(pid);
  expect(() => process.kill(pid, 0)).toThrow(); // the hung process is gone, not left stopped
  const again = await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0.3, 0, -0.6, 0, 0.3, 0]) });
  expect(again.body.status).toBe("reached");
});

it("an addObstacle that got no answer is not applied later: the name is free and nothing blocks", async () => {
  const pid = s.backend.pid!;
  process.kill(pid, "SIGSTOP");
  const ghost = { name: "ghost", shape: { type: "box", size: [0.3, 0.3, 0.3] }, position: [0.5, 0, 0.5] };
  const r = await invoke(base, "addObstacle", ghost);
  expect(r.status).toBe(503);
  await s.backend.waitUp(60_000);
  expect(s.backend.pid).not.toBe(pid);
  expect((await invoke(base, "removeObstacle", { name: "ghost" })).status).toBe(404);
  expect((await invoke(base, "addObstacle", ghost)).status).toBe(200);
  expect((await invoke(base, "removeObstacle", { name: "ghost" })).status).toBe(200);
});
