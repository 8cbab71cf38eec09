/**
 * runProgram: the program validateProgram plans, run as one timed motion (the reported duration is the
 * planned cycle time), synchronously or asynchronously (ActionStatus with the running step and progress;
 * cancel stops it); a refused step answers 422 with the report and nothing moves; with `--relay` the
 * physical robot (a second servient) gets the steps one after the other once the simulation has run them,
 * and the answer reports each. Real servients, real backends, real HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, waitFor } from "./serve-helpers.js";

const HOME = kukaPose([0, 0.6, 0, -1.2, 0, 0.6, 0]);

let physical: RunningServient;
let twin: RunningServient;
let pBase: string;
let base: string;

beforeAll(async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  physical = await startServient({ twins: [dir], port: 0, realtime: 0 });
  pBase = `${physical.url}/${physical.things[0]!.slug}`;
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1, relay: pBase, monitor: "warn" });
  base = `${twin.url}/${twin.things[0]!.slug}`;
});
afterAll(async () => {
  await twin?.stop();
  await physical?.stop();
});

const joints = async (b: string): Promise<Record<string, number>> => (await http(`${b}/properties/getJointPosition`)).body;

/** From HOME (where the robot is): PTP home, LIN 15 cm along y, CIRC back through a point 6 cm up, PTP to a joint target. */
async function program(): Promise<Record<string, unknown>[]> {
  expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
  const at = (await http(`${base}/properties/getCartesianPosition`)).body;
  return [
    { joints: HOME, speed: 0.8 },
    { motion: "lin", x: at.x, y: at.y + 0.15, z: at.z, tcpSpeed: 0.3 },
    { motion: "circ", via: { x: at.x, y: at.y + 0.075, z: at.z + 0.06 }, x: at.x, y: at.y, z: at.z },
    { joints: kukaPose([0.3, 0.5, 0, -1.0, 0, 0.5, 0]), acceleration: 0.5 },
  ];
}

it("runs what validateProgram planned in its cycle time, then relays the steps one after the other", async () => {
  const steps = await program();
  const plan = (await invoke(base, "validateProgram", { steps })).body;
  expect(plan.valid).toBe(true);
  const t0 = performance.now();
  const r = await invoke(base, "runProgram", { steps });
  const wall = (performance.now() - t0) / 1000;
  expect(r.status).toBe(200);
  expect(r.body).toMatchObject({ status: "reached", step: 3 });
  expect(r.body.duration).toBeCloseTo(plan.cycleTime, 9);
  expect(r.body.cycleTime).toBeCloseTo(plan.cycleTime, 9);
  expect(wall).toBeGreaterThanOrEqual(plan.cycleTime * 0.98);
  expect(r.body.relay).toEqual({ ok: true, steps: [0, 1, 2, 3].map((step) => ({ step, ok: true })) });
  expect((await http(`${base}/properties/physicalState`)).body).toMatchObject({ following: true });
  const end = await joints(base);
  const there = await joints(pBase);
  for (const [name, v] of Object.entries(kukaPose([0.3, 0.5, 0, -1.0, 0, 0.5, 0]))) {
    expect(end[name]).toBeCloseTo(v, 6);
    expect(there[name]).toBeCloseTo(v, 6);
  }
  const td = (await http(base)).body;
  expect(td.actions.runProgram.input.properties.steps.items.properties.tcpSpeed.unit).toBe("m/s");
  // blended (a 2 cm radius at the LIN's end): no stop between LIN and CIRC. The CIRC sets off back the way
  // the LIN came: through so tight a turn the TCP's total acceleration limit (tangential and centripetal)
  // slows the blend about as much as stopping costs, so the cycle time stays near the unblended one
  const blended = steps.map((s, k) => (k === 1 ? { ...s, blend: 0.02 } : s));
  const round = (await invoke(base, "validateProgram", { steps: blended })).body;
  expect(round.valid).toBe(true);
  expect(round.steps[1].blended).toBe(true);
  expect(round.cycleTime).toBeLessThan(plan.cycleTime * 1.1);
  expect(td.actions.runProgram.forms.some((f: any) => f.op.includes("cancelaction"))).toBe(true);
});

it("asynchronously: the ActionStatus names the running step; a cancel stops the run in simulation and relays nothing", async () => {
  const steps = await program();
  const physicalBefore = await joints(pBase);
  const started = await fetch(`${base}/actions/runProgram`, {
    method: "POST",
    headers: { "content-type": "application/json", prefer: "respond-async" },
    body: JSON.stringify({ steps: [...steps, ...steps] }),
  });
  expect(started.status).toBe(201);
  const href = started.headers.get("location")!;
  const seen: { status: string; step?: number; progress: number }[] = [];
  await waitFor(async () => {
    const s = await (await fetch(href)).json();
    seen.push(s);
    return (s.status === "running" && (s.step ?? 0) >= 2) || !["pending", "running"].includes(s.status);
  }, { what: "the run in step 2" });
  const running = seen.filter((s) => s.status === "running");
  expect(running.length).toBeGreaterThan(0);
  expect(running.at(-1)!.step).toBeGreaterThanOrEqual(2);
  for (let i = 1; i < running.length; i++) expect(running[i]!.step!).toBeGreaterThanOrEqual(running[i - 1]!.step!);
  const cancelled = await fetch(href, { method: "DELETE" });
  expect(cancelled.status).toBe(204);
  // the WoT Profile: a cancelled invocation's ActionStatus is deleted; the run ended stopped, short of its end
  expect((await fetch(href)).status).toBe(404);
  const status = await (await fetch(`${base}/properties/motionStatus`)).json();
  expect(status.state, JSON.stringify(status)).toBe("stopped");
  expect(await joints(pBase)).toEqual(physicalBefore);
});

it("a program whose LIN crosses an obstacle answers 422 naming step 1 with the report, and nothing moves", async () => {
  const steps = await program();
  const at = steps[1] as { x: number; y: number; z: number };
  const before = await joints(base);
  const physicalBefore = await joints(pBase);
  const wall = { name: "wall", shape: { type: "box", size: [0.3, 0.02, 0.3] }, position: [at.x, at.y - 0.07, at.z] };
  expect((await invoke(base, "addObstacle", wall)).status).toBe(200);
  try {
    const r = await invoke(base, "runProgram", { steps });
    expect(r.status).toBe(422);
    expect(r.body.details.program.firstFailingStep, JSON.stringify(r.body.details.program.steps[0].reasons)).toBe(1);
    expect(r.body.details.program.steps[1].reasons[0]).toMatch(/^LIN refused: the line collides \(.*wall/);
    expect(r.body.details.reasons[0]).toMatch(/^step 1: LIN refused/);
  } finally {
    await invoke(base, "removeObstacle", { name: "wall" });
  }
  expect(await joints(base)).toEqual(before);
  expect(await joints(pBase)).toEqual(physicalBefore);
});
