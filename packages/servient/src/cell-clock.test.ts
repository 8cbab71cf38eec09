/**
 * The cell clock in-process: a `SimClient` over a fake RPC caller (answers `cell.advance` at once, later, or
 * never), a fake backend (`isUp`) and vitest's fake clock. Idle without a running belt, `dt` from wall time
 * x realtime capped to the contract's, one call in flight (ticks skipped while one hangs), paused while
 * the backend is down and resumed after.
 */
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { BackendDownError, SimClient, type CellAdvanced, type RpcCaller } from "@robwot/sim-client";
import { afterEach, beforeEach, expect, it, vi } from "vitest";
import { CELL_TICK_MS, CellClock } from "./cell-clock.js";

const MAX_DT = VALUE_SCHEMAS.CellDt.maximum;

/** `cell.advance` answered after `delayMs` (0: at once, null: never), or refused as down while `down`. */
class FakeCaller implements RpcCaller {
  readonly dts: number[] = [];
  delayMs: number | null = 0;
  down = false;
  time = 0;

  async call<T>(method: string, params: Record<string, unknown> = {}): Promise<T> {
    if (method !== "cell.advance") throw new Error(`the fake backend has no ${method}`);
    if (this.down) throw new BackendDownError("simulation backend is restarting; retry shortly");
    const dt = params["dt"] as number;
    this.dts.push(dt);
    if (this.delayMs === null) return new Promise<T>(() => undefined);
    if (this.delayMs > 0) await new Promise((r) => setTimeout(r, this.delayMs!));
    this.time += dt;
    const moved = [{ name: "cube", shape: { type: "box", size: [0.04, 0.04, 0.04] }, position: [0, this.time, 0], orientation: [0, 0, 0, 1], mass: 0.1 }];
    return { time: this.time, moved, events: [], sensors: [] } as unknown as T;
  }

  onNotification(): () => void {
    return () => undefined;
  }

  async close(): Promise<void> {}
}

let caller: FakeCaller;
let backend: { sim: SimClient; isUp: boolean };
let answers: CellAdvanced[];
let errors: unknown[];
let clock: CellClock;
const run = (ms: number): Promise<void> => vi.advanceTimersByTimeAsync(ms).then(() => undefined);

function makeClock(realtime: number): CellClock {
  return new CellClock(backend, { realtime, onAdvanced: (r) => answers.push(r), onError: (e) => errors.push(e) });
}

beforeEach(() => {
  vi.useFakeTimers({ now: 1_000_000 });
  caller = new FakeCaller();
  backend = { sim: new SimClient(caller), isUp: true };
  answers = [];
  errors = [];
  clock = makeClock(1);
});
afterEach(async () => {
  await clock.stop();
  vi.useRealTimers();
});

it("makes no call while no belt runs", async () => {
  await run(10 * CELL_TICK_MS);
  expect(caller.dts).toEqual([]);
  clock.setRunning(true);
  clock.setRunning(false);
  await run(10 * CELL_TICK_MS);
  expect(caller.dts).toEqual([]);
  expect(clock.ticking).toBe(false);
});

it("advances by the wall time of a tick x realtime while a belt runs, and stops when none does", async () => {
  clock.setRunning(true);
  await run(4 * CELL_TICK_MS);
  expect(caller.dts).toHaveLength(4);
  for (const dt of caller.dts) expect(dt).toBeCloseTo(CELL_TICK_MS / 1000, 9);
  expect(answers.map((a) => a.time)).toHaveLength(4);
  expect(answers.at(-1)!.moved[0]!.position[1]).toBeCloseTo((4 * CELL_TICK_MS) / 1000, 9);
  clock.setRunning(false);
  await run(10 * CELL_TICK_MS);
  expect(caller.dts).toHaveLength(4);
});

it("scales dt by the realtime factor, capped to the contract's largest dt; realtime 0 takes the largest", async () => {
  await clock.stop();
  clock = makeClock(4);
  clock.setRunning(true);
  await run(CELL_TICK_MS);
  expect(caller.dts[0]).toBeCloseTo((4 * CELL_TICK_MS) / 1000, 9);
  await clock.stop();
  clock = makeClock(1000);
  clock.setRunning(true);
  await run(CELL_TICK_MS);
  expect(caller.dts[1]).toBe(MAX_DT);
  await clock.stop();
  clock = makeClock(0);
  clock.setRunning(true);
  await run(CELL_TICK_MS);
  expect(caller.dts[2]).toBe(MAX_DT);
});

it("keeps one call in flight: a hung call skips the ticks, never piles calls up", async () => {
  caller.delayMs = null;
  clock.setRunning(true);
  await run(20 * CELL_TICK_MS);
  expect(caller.dts).toHaveLength(1);
  expect(clock.counts.busy).toBe(19);
});

it("skips ticks while an answer is slow, then advances by the wall time since the last call", async () => {
  caller.delayMs = 3 * CELL_TICK_MS - 1;
  clock.setRunning(true);
  await run(CELL_TICK_MS); // call 1 sent
  await run(3 * CELL_TICK_MS); // answered; the ticks meanwhile skipped; call 2 sent at the 4th tick
  expect(caller.dts).toHaveLength(2);
  expect(caller.dts[1]).toBeCloseTo((3 * CELL_TICK_MS) / 1000, 9);
  expect(clock.counts.busy).toBe(2);
});

it("pauses while the backend is down and resumes once it is up, dt counted from then", async () => {
  clock.setRunning(true);
  await run(2 * CELL_TICK_MS);
  expect(caller.dts).toHaveLength(2);
  backend.isUp = false;
  await run(40 * CELL_TICK_MS);
  expect(caller.dts).toHaveLength(2);
  expect(clock.counts.down).toBe(40);
  backend.isUp = true;
  clock.resume();
  await run(CELL_TICK_MS);
  expect(caller.dts).toHaveLength(3);
  expect(caller.dts[2]).toBeCloseTo(CELL_TICK_MS / 1000, 9);
});

it("a call refused as down pauses the clock without an error report", async () => {
  clock.setRunning(true);
  caller.down = true;
  backend.isUp = false;
  await run(CELL_TICK_MS);
  backend.isUp = true;
  caller.down = true;
  await run(CELL_TICK_MS);
  expect(errors).toEqual([]);
  caller.down = false;
  await run(CELL_TICK_MS);
  expect(caller.dts.length).toBeGreaterThan(0);
  expect(answers.length).toBeGreaterThan(0);
});

it("reports another failure once until a call succeeds again", async () => {
  const failing = new CellClock({ sim: { advanceCell: () => Promise.reject(new Error("boom")) } as unknown as SimClient, isUp: true }, { realtime: 1, onAdvanced: () => undefined, onError: (e) => errors.push(e) });
  failing.setRunning(true);
  await run(5 * CELL_TICK_MS);
  expect(errors).toHaveLength(1);
  await failing.stop();
});
