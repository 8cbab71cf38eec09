/**
 * The physical robot's stop first: with `relay`, a stop reaches the physical robot at once and whatever
 * the simulation does (hung backend included), and every path that ends a relayed move early stops the
 * physical robot too (the relayed move's deadline, the backend going down, servient shutdown). The
 * physical robot is a second twin served by `startServient` (`realtime: 1`) whose joints are 20 times
 * slower than the model the relaying twin simulates, so its relayed motions run for many seconds.
 * Real servients, real backends, real HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, slowPhysicalTwin, waitFor, waitMoved, waitState, type HttpAnswer } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
const target = (j1: number): Record<string, number> => kukaPose([j1, 0.3, 0, -0.8, 0, 0.4, 0]);

let physical: RunningServient;
let twin: RunningServient;
let pBase: string;
let vBase: string;
const stoppedPids: number[] = [];

beforeAll(async () => {
  physical = await startServient({ twins: [await slowPhysicalTwin()], port: 0, realtime: 1 });
  pBase = `${physical.url}/${physical.things[0]!.slug}`;
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: pBase });
  vBase = `${twin.url}/${twin.things[0]!.slug}`;
});

afterAll(async () => {
  for (const pid of stoppedPids) {
    try {
      process.kill(pid, "SIGCONT");
    } catch {
      // killed by the supervisor already: nothing to resume
    }
  }
  await twin?.stop();
  await physical?.stop();
});

const physicalJ1 = async (): Promise<number> => (await http(`${pBase}/properties/getJointPosition`)).body[J1];

/** Sends a move to the relaying twin and resolves once the physical robot is really moving (the move's
 *  answer wrapped: an async function returning a promise would wait for it). */
async function relayedMove(base: string, j1: number, speed: number): Promise<{ answer: Promise<HttpAnswer> }> {
  const from = await physicalJ1();
  const answer = invoke(base, "moveToJointPosition", { joints: target(j1), speed });
  answer.catch(() => undefined); // awaited by the test, or closed with a servient it shuts down
  const ended = answer.then((r) => {
    throw new Error(`the relayed move ended before the physical robot was seen moving: ${r.status} ${JSON.stringify(r.body)}`);
  });
  await Promise.race([waitMoved(pBase, J1, from), ended]);
  ended.catch(() => undefined);
  return { answer };
}

/** Until the physical robot reports `stopped` (a robot that moves on fails the wait). */
const physicalStopped = (): Promise<void> => waitState(pBase, "stopped");

/** Whether `p` has settled, read at any time: what an ordering assertion compares with. */
function settledFlag(p: Promise<unknown>): () => boolean {
  let settled = false;
  void p.then(
    () => (settled = true),
    () => (settled = true),
  );
  return () => settled;
}

/** Waits until the supervisor has replaced the backend `pid` (killed, restarted, world restored). */
async function replaced(pid: number): Promise<void> {
  await waitFor(() => twin.backend.pid !== pid && twin.backend.isUp, { timeoutMs: 60_000, what: `backend ${pid} replaced` });
}

/** The physical robot stands still: stopped, its motion ended (the status follows its backend's answer, after
 *  every state of the motion), so a later round trip through its backend finds the joints unchanged. */
async function standsStill(): Promise<number> {
  await physicalStopped();
  const a = await physicalJ1();
  expect((await invoke(pBase, "validateJointPosition", { joints: target(0) })).status).toBe(200);
  const b = await physicalJ1();
  expect(b).toBe(a);
  return b;
}

it("a relayed move the physical robot does not finish within its deadline is stopped there", async () => {
  // simulated in 1.04 s (1.5 rad at 10 rad/s x 0.15, plus 2 x 0.0375 s of ramps at 40 rad/s^2 minus their
  // 0.0375 s at cruise); deadline 3 x 1.04 s + 10 s; the physical robot needs 20 s
  const r = await invoke(vBase, "moveToJointPosition", { joints: target(1.5), speed: 0.15 });
  expect(r.status, JSON.stringify(r.body)).toBe(200);
  expect(r.body.status).toBe("reached");
  expect(r.body.duration).toBeCloseTo(1, 1);
  expect(r.body.relay.ok).toBe(false);
  // ended by its deadline, the stop confirmed by the physical robot
  expect(r.body.relay.error).toMatch(/stopped by the twin \(relayed moveToJointPosition without an answer .*within 131\d\d ms.*\); stop confirmed/);
  const j1 = await standsStill();
  expect(j1).toBeGreaterThan(0.2);
  expect(j1).toBeLessThan(1.45);
  expect((await http(`${vBase}/properties/motionStatus`)).body.lastError.code).toBe("E_RELAY");
});

it("a stop during the physical motion stops the physical robot at once and reports both outcomes", async () => {
  const { answer: move } = await relayedMove(vBase, -1.5, 0.05);
  const s = await invoke(vBase, "stop", "");
  expect(s.status).toBe(200);
  // the first stop sent was confirmed by the physical robot
  expect(s.body).toEqual({ stopped: true, simulation: { ok: true }, physical: { ok: true, attempts: 1 } });
  await standsStill();
  const r = await move;
  expect(r.body.status).toBe("stopped");
  expect(r.body.relay.ok).toBe(false);
  // the physical robot's answer to the command ("stopped"), or, when the confirmation of its stop came
  // first, the stop that ended the wait for it (RelaySession.move: a stop ends the wait at once)
  expect(r.body.relay.result?.status ?? r.body.relay.error, JSON.stringify(r.body.relay)).toBe("stopped");
});

it("with the twin's backend hung (SIGSTOP), stop still answers 200, the physical robot stopped at once", async () => {
  const { answer: move } = await relayedMove(vBase, 1.5, 0.05);
  const pid = twin.backend.pid!;
  process.kill(pid, "SIGSTOP");
  stoppedPids.push(pid);
  const stop = invoke(vBase, "stop", "");
  const answered = settledFlag(stop);
  // the physical robot is stopped while the stop still waits for the hung simulation (until its deadline)
  await physicalStopped();
  expect(answered(), "the stop answered before the physical robot was seen stopped").toBe(false);
  const s = await stop;
  expect(s.status).toBe(200);
  expect(s.body.stopped).toBe(true);
  expect(s.body.physical).toEqual({ ok: true, attempts: 1 });
  expect(s.body.simulation.ok).toBe(false);
  expect(typeof s.body.simulation.error).toBe("string");
  await standsStill();
  await move;
  await replaced(pid);
});

it("the twin's backend going down (heartbeat deadline) during a relayed motion stops the physical robot", async () => {
  // simulated in 15 s: the relayed move's own deadline (55 s) is far away
  const { answer: move } = await relayedMove(vBase, -1.5, 0.02);
  const pid = twin.backend.pid!;
  process.kill(pid, "SIGSTOP");
  stoppedPids.push(pid);
  // declared dead when a ping stays unanswered (the heartbeat's deadline): the move's answer names it
  await standsStill();
  const r = await move;
  expect(r.body.relay.ok).toBe(false);
  expect(r.body.relay.error).toMatch(/stopped by the twin \(simulation backend down: .*\); stop confirmed/);
  await replaced(pid);
});

it("cancelling a relayed asynchronous move (DELETE) with the twin's backend hung stops the physical robot at once", async () => {
  const from = await physicalJ1();
  const r = await fetch(`${vBase}/actions/moveToJointPosition`, {
    method: "POST",
    headers: { "content-type": "application/json", prefer: "respond-async" },
    body: JSON.stringify({ joints: target(1.5), speed: 0.02 }),
  });
  expect(r.status).toBe(201);
  const href = r.headers.get("location")!;
  await waitMoved(pBase, J1, from);
  const pid = twin.backend.pid!;
  process.kill(pid, "SIGSTOP");
  stoppedPids.push(pid);
  const cancel = fetch(href, { method: "DELETE" });
  const answered = settledFlag(cancel);
  // stopped while the DELETE still waits for the move's end (the hung backend's, at the heartbeat's deadline)
  await physicalStopped();
  expect(answered(), "the DELETE answered before the physical robot was seen stopped").toBe(false);
  expect((await cancel).status).toBe(204);
  await standsStill();
  await replaced(pid);
});

it("shutting down a relaying servient stops the physical robot it commanded", async () => {
  const other = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: pBase });
  try {
    const base = `${other.url}/${other.things[0]!.slug}`;
    await relayedMove(base, 1.5, 0.02);
    await other.stop();
    // a robot left moving would run on for over a minute
    await standsStill();
  } finally {
    await other.stop();
  }
});

it("a physical robot that does not answer: stop retries until the deadline, then says so (200, not 503)", async () => {
  await physical.stop();
  const s = await invoke(vBase, "stop", "");
  expect(s.status).toBe(200);
  expect(s.body.simulation).toEqual({ ok: true });
  // retried, then ended by the deadline
  expect(s.body.physical.ok).toBe(false);
  expect(s.body.physical.attempts).toBeGreaterThan(1);
  expect(s.body.physical.error).toMatch(/no answer to stop within 5000 ms/);
  expect((await http(`${vBase}/properties/motionStatus`)).body.lastError.code).toBe("E_RELAY");
});
