/**
 * The moves in-process: the motion session (busy, stop at every stage, status) and the relay session
 * (deadline, backend down, a program's first failed step) through the `Mover` that composes them, over a
 * fake backend (a `SimClient` on a fake RPC caller whose motions run on simulated time), a fake physical
 * Thing behind the real `Relay`, and vitest's fake clock: every outcome is a function of simulated time.
 */
import { EventEmitter } from "node:events";
import { SimClient, type RpcCaller } from "@robwot/sim-client";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import { ServientError } from "./errors.js";
import { Mover, RELAY_MOVE_DEADLINE, type MoveHandle } from "./moves.js";
import { Relay } from "./relay.js";
import type { TwinFolder } from "./twin-folder.js";
import { Twin } from "./twin.js";

const JOINTS = ["j1", "j2"];
/** s of simulated time each motion (a move, a program step) takes */
const MOTION_S = 1;
/** ms the fake backend plans before its motion starts */
const PLAN_MS = 50;
/** ms between two streamed states */
const TICK_MS = 20;

interface Deferred<T> {
  promise: Promise<T>;
  resolve(v: T): void;
}
function deferred<T>(): Deferred<T> {
  let resolve!: (v: T) => void;
  const promise = new Promise<T>((res) => (resolve = res));
  return { promise, resolve };
}

/** The backend: `robot.move` and `program.run` plan for `PLAN_MS`, then stream states over `MOTION_S` per step until `robot.stop`. */
class FakeBackendCaller implements RpcCaller {
  readonly calls: string[] = [];
  /** the params of each `robot.move` */
  readonly moves: Record<string, unknown>[] = [];
  private readonly listeners: ((method: string, params: Record<string, unknown>) => void)[] = [];
  private halt: (() => void) | null = null;
  q = [0, 0];

  async call<T>(method: string, params: Record<string, unknown> = {}): Promise<T> {
    this.calls.push(method);
    if (method === "robot.stop") {
      const moving = this.halt !== null;
      this.halt?.();
      return { stopped: moving } as T;
    }
    // a pose target (no joint vector) leaves the fake robot where it is
    if (method === "robot.move") this.moves.push(params);
    if (method === "robot.move") return (await this.run([(params.target as number[] | undefined) ?? []])) as T;
    if (method === "program.run") return (await this.run((params.steps as { target?: number[] }[]).map((s) => s.target ?? []))) as T;
    throw new Error(`the fake backend has no ${method}`);
  }

  onNotification(_method: string, listener: (method: string, params: Record<string, unknown>) => void): () => void {
    this.listeners.push(listener);
    return () => undefined;
  }

  async close(): Promise<void> {}

  private async run(targets: number[][]): Promise<object> {
    await new Promise((r) => setTimeout(r, PLAN_MS));
    const planned = targets.length * MOTION_S;
    let stopped = false;
    this.halt = () => (stopped = true);
    const ticks = Math.round((MOTION_S * 1000) / TICK_MS);
    // simulated time counted in whole ticks: the durations it answers are exact
    let elapsed = 0;
    const time = (): number => (elapsed * TICK_MS) / 1000;
    let step = 0;
    try {
      for (; step < targets.length && !stopped; step++) {
        const from = [...this.q];
        for (let k = 1; k <= ticks && !stopped; k++) {
          await new Promise((r) => setTimeout(r, TICK_MS));
          elapsed++;
          this.q = from.map((v, i) => v + ((targets[step]![i] ?? v) - v) * (k / ticks));
          const state = { robot: "arm", time: time(), planned, positions: this.q, moving: true, position: [this.q[0], this.q[1], 0], orientation: [0, 0, 0, 1], ...(targets.length > 1 ? { step } : {}) };
          for (const l of this.listeners) l("robot.state", state);
        }
      }
    } finally {
      this.halt = null;
    }
    const steps = targets.map((_, k) => ({ step: k, ok: true, reasons: [], checks: {}, duration: MOTION_S }));
    const plan = { valid: true, reasons: [], checks: {} };
    const program = { valid: true, firstFailingStep: null, cycleTime: planned, steps, trajectory: { rate: 50, names: JOINTS, positions: [] } };
    return { status: stopped ? "stopped" : "reached", positions: this.q, duration: time(), wallTime: time(), contacts: [], step: Math.max(0, step - 1), plan, program };
  }
}

/** The physical robot's Thing: each command waits for `answer` (default: reached at once); stops are counted. */
class FakeThing {
  readonly commands: { action: string; input: unknown }[] = [];
  stops = 0;
  answer: (action: string, n: number) => Promise<unknown> = async () => ({ status: "reached" });

  async invokeAction(action: string, input?: unknown): Promise<{ value(): Promise<unknown> }> {
    if (action === "stop") {
      this.stops++;
      return { value: async () => ({ stopped: true }) };
    }
    this.commands.push({ action, input });
    const v = await this.answer(action, this.commands.length - 1);
    return { value: async () => v };
  }
}

function harness({ relay = false } = {}) {
  const caller = new FakeBackendCaller();
  const backend = Object.assign(new EventEmitter(), { isUp: true, sim: new SimClient(caller) });
  const folder = { calibration: null, manifest: { robot: {} } } as unknown as TwinFolder;
  const twin = new Twin("arm", folder, backend as never);
  twin.model = { name: "arm", eeLink: "ee", controllable: JOINTS, joints: JOINTS.map((name) => ({ name, type: "revolute" as const, lower: -3, upper: 3, velocity: 2, effort: 1 })) };
  twin.q = [0, 0];
  backend.sim.on("robot.state", (p) => twin.onState(p));
  const thing = new FakeThing();
  const wot = { requestThingDescription: async () => ({ title: "arm" }), consume: async () => thing };
  const mover = new Mover(backend, twin, null, 1, relay ? new Relay(wot, "http://robot.test/arm") : null);
  return { caller, backend, twin, thing, mover };
}

const run = (ms: number): Promise<void> => vi.advanceTimersByTimeAsync(ms).then(() => undefined);
/** Runs a move's planning and motion to their end (and the relay's first command on its way). */
const simulated = (): Promise<void> => run(PLAN_MS + MOTION_S * 1000 + TICK_MS);
const TARGET = { joints: { j1: 1, j2: 0.5 } };

beforeEach(() => {
  vi.useFakeTimers({ now: Date.parse("2026-03-01T00:00:00Z") });
});
afterEach(() => {
  vi.useRealTimers();
});

describe("motion session", () => {
  it("a move while another holds the twin is refused 409 E_BUSY; once it ended a move is accepted", async () => {
    const h = harness();
    const first = h.mover.moveJoints(TARGET);
    const refused = await h.mover.moveJoints(TARGET).catch((e: unknown) => e);
    expect(refused).toBeInstanceOf(ServientError);
    expect(refused).toMatchObject({ status: 409, code: "E_BUSY" });
    await simulated();
    expect((await first).status).toBe("reached");
    expect(h.twin.motion.busy).toBe(false);
    const second = h.mover.moveJoints({ joints: { j1: 0, j2: 0 } });
    await simulated();
    expect((await second).status).toBe("reached");
    expect(h.caller.calls.filter((m) => m === "robot.move")).toHaveLength(2);
  });

  it("a stop before the backend call answers stopped and sends no motion", async () => {
    const h = harness();
    let stop: Promise<unknown> | undefined;
    const moved = h.mover.moveJoints(TARGET, () => (stop = h.mover.stop()));
    const result = await moved;
    expect(result).toMatchObject({ status: "stopped", duration: 0, joints: { j1: 0, j2: 0 } });
    expect(await stop).toMatchObject({ stopped: true, simulation: { ok: true } });
    expect(h.caller.calls).not.toContain("robot.move");
    expect(h.twin.status).toMatchObject({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped before the motion started" } });
  });

  it("a stop during the motion answers stopped where the backend stopped it, and the status says so", async () => {
    const h = harness();
    let handle: MoveHandle | undefined;
    const moved = h.mover.moveJoints(TARGET, (m) => (handle = m));
    expect(handle?.phase()).toBe("pending");
    await run(PLAN_MS + (MOTION_S * 1000) / 2);
    expect(handle?.phase()).toBe("running");
    expect(handle?.progress()).toBeCloseTo(0.5, 1);
    const report = await h.mover.stop();
    // the backend ends its motion at its next state
    await run(TICK_MS);
    const result = await moved;
    expect(report).toEqual({ stopped: true, simulation: { ok: true } });
    expect(result.status).toBe("stopped");
    expect(result.joints.j1).toBeGreaterThan(0);
    expect(result.joints.j1).toBeLessThan(1);
    expect(h.twin.status).toMatchObject({ state: "stopped", lastError: { code: "E_STOPPED", message: "motion stopped before reaching the target" } });
    expect(h.twin.motion.busy).toBe(false);
  });

  it("a stop with the backend down is answered, its simulation part failed", async () => {
    const h = harness();
    h.backend.isUp = false;
    expect(await h.mover.stop()).toMatchObject({ stopped: false, simulation: { ok: false, error: expect.stringMatching(/backend down/) } });
  });

  it("a refused plan answers 422 E_REJECTED with the twin's state as before", async () => {
    const h = harness();
    h.caller.call = async <T>(method: string): Promise<T> => {
      throw new ServientError(422, "E_REJECTED", `${method} refused`, { reasons: ["joint j1 beyond its limit"], checks: {} });
    };
    const refused = await h.mover.moveJoints(TARGET).catch((e: unknown) => e);
    expect(refused).toMatchObject({ status: 422, code: "E_REJECTED", details: { reasons: ["joint j1 beyond its limit"] } });
    expect(h.twin.status).toMatchObject({ state: "idle", lastError: { code: "E_REJECTED" } });
    expect(h.twin.motion.busy).toBe(false);
  });
});

describe("relay session", () => {
  it("a completed move is relayed once, and the relayed states are readable only while it runs", async () => {
    const h = harness({ relay: true });
    const answer = deferred<unknown>();
    h.thing.answer = () => answer.promise;
    const moved = h.mover.moveJoints(TARGET);
    await simulated();
    expect(h.thing.commands).toEqual([{ action: "moveToJointPosition", input: { joints: { j1: 1, j2: 0.5 }, speed: 1 } }]);
    expect(h.twin.motion.relayed?.states[0]).toMatchObject({ time: 0, q: [0, 0] });
    expect(h.twin.motion.relayed?.states.at(-1)?.q).toEqual([1, 0.5]);
    answer.resolve({ status: "reached" });
    const result = await moved;
    expect(result.relay).toMatchObject({ ok: true, action: "moveToJointPosition" });
    expect(result.status).toBe("reached");
    expect(h.twin.motion.relayed).toBeNull();
    expect(h.thing.stops).toBe(0);
  });

  it("a relayed move has the twin run a detour at rest between its legs, as the physical robot runs them; an unrelayed one smoothly", async () => {
    const relayed = harness({ relay: true });
    relayed.thing.answer = () => Promise.resolve({ status: "reached" });
    const moved = relayed.mover.moveJoints(TARGET);
    await simulated();
    await moved;
    expect(relayed.caller.moves.map((p) => p.detour)).toEqual(["stops"]);
    const alone = harness();
    const alsoMoved = alone.mover.moveJoints(TARGET);
    await simulated();
    await alsoMoved;
    expect(alone.caller.moves.map((p) => p.detour)).toEqual([undefined]);
  });

  it("a stop while the physical robot runs the command stops it there and answers stopped", async () => {
    const h = harness({ relay: true });
    h.thing.answer = () => new Promise(() => undefined);
    const moved = h.mover.moveJoints(TARGET);
    await simulated();
    expect(h.thing.commands).toHaveLength(1);
    const report = await h.mover.stop();
    const result = await moved;
    expect(report).toMatchObject({ stopped: true, physical: { ok: true, attempts: 1 } });
    expect(h.thing.stops).toBe(1);
    expect(result.status).toBe("stopped");
    expect(result.relay).toMatchObject({ ok: false, error: "stopped" });
    expect(h.twin.status).toMatchObject({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped while the physical robot ran the command" } });
  });

  it("a relayed leg unanswered at its deadline stops the physical robot, and the report and status say why", async () => {
    const h = harness({ relay: true });
    h.thing.answer = () => new Promise(() => undefined);
    const moved = h.mover.moveJoints(TARGET);
    await simulated();
    const sentAt = h.twin.motion.relayed?.sentAt ?? Number.NaN;
    const deadline = sentAt + MOTION_S * 1000 * RELAY_MOVE_DEADLINE.factor + RELAY_MOVE_DEADLINE.marginMs;
    await run(deadline - Date.now() - 1);
    expect(h.thing.stops).toBe(0);
    await run(1);
    const result = await moved;
    expect(h.thing.stops).toBe(1);
    expect(result.relay).toMatchObject({ ok: false, error: expect.stringMatching(/^stopped by the twin \(relayed moveToJointPosition without an answer .*\); stop confirmed after 1 attempt/) });
    expect(h.twin.status.lastError).toMatchObject({ code: "E_RELAY" });
  });

  it("the backend going down during a relayed command stops the physical robot", async () => {
    const h = harness({ relay: true });
    const answer = deferred<unknown>();
    h.thing.answer = () => answer.promise;
    const moved = h.mover.moveJoints(TARGET);
    await simulated();
    h.backend.emit("down", "heartbeat deadline passed");
    expect(h.thing.stops).toBe(1);
    expect(h.twin.status.lastError).toEqual({ code: "E_RELAY", message: "physical robot stopped: simulation backend down: heartbeat deadline passed" });
    answer.resolve({ status: "reached" });
    const result = await moved;
    expect(result.relay).toMatchObject({ ok: false, error: expect.stringMatching(/^stopped by the twin \(simulation backend down: heartbeat deadline passed\)/) });
  });

  it("the backend going down while nothing is relayed sends the physical robot no stop", async () => {
    const h = harness({ relay: true });
    const moved = h.mover.moveJoints(TARGET);
    await run(PLAN_MS);
    h.backend.emit("down", "connection lost");
    await simulated();
    expect((await moved).relay).toMatchObject({ ok: true });
    expect(h.thing.stops).toBe(0);
  });

  it.each([
    ["answers a failed motion", async () => ({ status: "collision" }), 0],
    ["does not answer", () => new Promise<unknown>(() => undefined), 1],
  ])("a program whose step 1 %s stops relaying there: step 2 is never sent", async (_what, failing, stops) => {
    const h = harness({ relay: true });
    h.thing.answer = (_a, n) => (n === 1 ? failing() : Promise.resolve({ status: "reached" }));
    const steps = [{ joints: { j1: 0.5, j2: 0 } }, { joints: { j1: 1, j2: 0 } }, { x: 0.3, y: 0, z: 0.2, motion: "lin" }];
    const ran = h.mover.runProgram({ steps });
    await run(PLAN_MS + 3 * MOTION_S * 1000 + TICK_MS);
    await run(3 * MOTION_S * 1000 * RELAY_MOVE_DEADLINE.factor + RELAY_MOVE_DEADLINE.marginMs);
    const out = await ran;
    expect(out.status).toBe("reached");
    expect(h.thing.commands.map((c) => c.action)).toEqual(["moveToJointPosition", "moveToJointPosition"]);
    expect(out.relay).toMatchObject({ ok: false, steps: [{ step: 0, ok: true }, { step: 1, ok: false }], error: expect.stringMatching(/^step 1: /) });
    expect(h.thing.stops).toBe(stops);
  });

  it("a Cartesian step is relayed as the move action takes it: the frame of the TD, motion only when not PTP", async () => {
    const h = harness({ relay: true });
    const ran = h.mover.runProgram({ steps: [{ x: 0.3, y: 0, z: 0.2, motion: "ptp" }, { x: 0.3, y: 0.1, z: 0.2, motion: "lin", speed: 0.5 }] });
    await run(PLAN_MS + 2 * MOTION_S * 1000 + TICK_MS);
    expect((await ran).relay).toMatchObject({ ok: true });
    expect(h.thing.commands.map((c) => c.input)).toEqual([
      { x: 0.3, y: 0, z: 0.2, speed: 1 },
      { x: 0.3, y: 0.1, z: 0.2, speed: 0.5, motion: "lin" },
    ]);
  });
});
