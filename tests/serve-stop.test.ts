/**
 * A stop always wins: whenever it arrives after a move was accepted — during validation, IK, the path
 * check or the motion — the move answers `stopped`, `stop` answers `{stopped: true, simulation: {ok: true}}`
 * and the twin does not go on moving. Real servient, real backend, real HTTP.
 */
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, sleep } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
const HOME = kukaPose([0, 0, 0, 0, 0, 0, 0]);
const FAR = kukaPose([1.5, 0.4, 0, -1.0, 0, 0.5, 0]);

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  base = `${s.url}/${s.things[0]!.slug}`;
});
afterAll(async () => s?.stop());

/** Resolves as soon as the servient has accepted the move (busy from acceptance until the answer). */
async function accepted(): Promise<void> {
  const twin = [...s.twins.values()][0]!;
  // polled on every turn of the event loop (a stop "0 ms after acceptance" means the next turn); the
  // deadline bounds a failure only
  const end = Date.now() + 30_000;
  while (!twin.busy) {
    if (Date.now() > end) throw new Error("the move was not accepted within 30 s");
    await new Promise((r) => setImmediate(r));
  }
}

const joints = async (): Promise<Record<string, number>> => (await http(`${base}/properties/getJointPosition`)).body;

/** Cartesian position of FAR, read from the twin itself (so the target is reachable). */
async function farPosition(): Promise<{ x: number; y: number; z: number }> {
  expect((await invoke(base, "moveToJointPosition", { joints: FAR })).body.status).toBe("reached");
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  return { x: p.x, y: p.y, z: p.z };
}

/** From home, starts `action` at speed 0.2, stops it `delay` ms after acceptance; checks both answers. */
async function stopAfter(action: string, input: object, delay: number): Promise<any> {
  expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
  const move = invoke(base, action, { ...input, speed: 0.2 });
  await accepted();
  // the stage the stop lands in is varied on purpose (no time is asserted: every stage must answer stopped)
  await sleep(delay);
  const stop = await invoke(base, "stop", "");
  const r = await move;
  expect(stop.body).toEqual({ stopped: true, simulation: { ok: true } });
  expect(r.status).toBe(200);
  expect(r.body.status).toBe("stopped");
  // the move answers once the backend's motion has ended, after every state of it: a later backend call
  // (a validation) is ordered after anything that could still move the twin
  expect((await invoke(base, "validateJointPosition", { joints: HOME })).status).toBe(200);
  return r.body;
}

describe("stop during any stage of a move", () => {
  const delays = [0, 1, 3, 10, 30, 100, 300];

  it.each(delays)("joint move, stop %i ms after acceptance: stopped, and the twin stays where the move answered", async (delay) => {
    const r = await stopAfter("moveToJointPosition", { joints: FAR }, delay);
    const after = await joints();
    for (const [name, v] of Object.entries(r.joints as Record<string, number>)) expect(after[name]).toBeCloseTo(v, 9);
    expect(after.lbr_iiwa_joint_1).toBeLessThan(1.49);
    expect((await http(`${base}/properties/motionStatus`)).body.state).toBe("stopped");
  });

  it.each(delays)("Cartesian move, stop %i ms after acceptance: stopped before reaching the target", async (delay) => {
    const target = await farPosition();
    const r = await stopAfter("moveToCartesianPosition", target, delay);
    const p = (await http(`${base}/properties/getCartesianPosition`)).body;
    expect(Math.hypot(p.x - r.position.x, p.y - r.position.y, p.z - r.position.z)).toBeLessThan(1e-9);
    expect(Math.hypot(p.x - target.x, p.y - target.y, p.z - target.z)).toBeGreaterThan(0.01);
  });

  it("a stop with nothing pending answers {stopped: false, simulation: {ok: true}}", async () => {
    expect((await invoke(base, "stop", "")).body).toEqual({ stopped: false, simulation: { ok: true } });
  });
});
