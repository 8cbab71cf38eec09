/**
 * The cell clock: one clock for the whole cell of a servient (every twin shares one world). While any belt
 * runs it calls `cell.advance {dt}` every tick: `dt` = the wall time since the last call x the realtime
 * factor (`--realtime`; 0, as fast as possible: the contract's largest `dt` per tick), at most the
 * contract's largest `dt` (`CellDt`). Idle when no belt runs: no calls at all.
 *
 * - One call in flight: a tick that finds the last call unanswered is skipped (a hung backend never has
 *   calls piled up on it; the supervisor's request deadline declares it dead).
 * - Backend down (`isUp` false, or a call refused as down): paused, no calls; resumed once the backend is
 *   up again (the world restored, belts running as recorded), its first `dt` counted from then.
 * - Every answer goes to `onAdvanced` (objects moved, sensor readings, events); another error is reported
 *   once to `onError` until a call succeeds again.
 */
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import type { CellAdvanced, SimClient } from "@robwot/sim-client";

/** ms of wall time between two ticks */
export const CELL_TICK_MS = 50;

/** What the clock needs of the backend supervisor. */
export interface ClockBackend {
  readonly sim: Pick<SimClient, "advanceCell">;
  readonly isUp: boolean;
}

export interface CellClockOptions {
  /** the realtime factor (`--realtime`): 1 = wall clock, 0 = as fast as possible */
  realtime: number;
  tickMs?: number;
  /** wall clock (ms); default Date.now */
  now?: () => number;
  onAdvanced(result: CellAdvanced): void;
  onError?(err: unknown): void;
}

export class CellClock {
  private timer: ReturnType<typeof setInterval> | null = null;
  private inFlight: Promise<void> | null = null;
  /** wall time (ms) the last call was sent, or the clock (re)started */
  private lastAt = 0;
  private paused = false;
  private failing = false;
  private stopped = false;
  /** calls sent, ticks skipped because one was in flight, ticks skipped because the backend was down */
  readonly counts = { calls: 0, busy: 0, down: 0 };
  private readonly tickMs: number;
  private readonly now: () => number;
  private readonly maxDt = VALUE_SCHEMAS.CellDt.maximum;

  constructor(
    private readonly backend: ClockBackend,
    private readonly opts: CellClockOptions,
  ) {
    this.tickMs = opts.tickMs ?? CELL_TICK_MS;
    this.now = opts.now ?? Date.now;
  }

  /** Whether the clock ticks (some belt runs). */
  get ticking(): boolean {
    return this.timer !== null;
  }

  /** Starts ticking while `running` (some belt runs), stops when not. */
  setRunning(running: boolean): void {
    if (this.stopped) return;
    if (running && this.timer === null) {
      this.lastAt = this.now();
      this.timer = setInterval(() => this.tick(), this.tickMs);
      this.timer.unref?.();
    } else if (!running && this.timer !== null) {
      clearInterval(this.timer);
      this.timer = null;
    }
  }

  /** The backend is up again (world restored): ticks resume, `dt` counted from now. */
  resume(): void {
    this.paused = false;
    this.lastAt = this.now();
  }

  /** Stops for good (servient shutdown): no more calls; the answer of a call in flight is dropped (a hung
   *  backend's call is never waited for). */
  async stop(): Promise<void> {
    this.setRunning(false);
    this.stopped = true;
    await Promise.resolve();
  }

  /** One tick: skipped while a call is in flight or the backend is down; else one `cell.advance`. */
  tick(): void {
    if (this.inFlight !== null) {
      this.counts.busy++;
      return;
    }
    if (!this.backend.isUp) {
      this.counts.down++;
      this.paused = true;
      return;
    }
    if (this.paused) this.resume();
    const now = this.now();
    const wall = Math.max(0, now - this.lastAt) / 1000;
    const dt = this.opts.realtime === 0 ? this.maxDt : Math.min(this.maxDt, wall * this.opts.realtime);
    if (!(dt > 0)) return;
    this.lastAt = now;
    this.counts.calls++;
    this.inFlight = this.advance(dt).finally(() => (this.inFlight = null));
  }

  private async advance(dt: number): Promise<void> {
    try {
      const result = await this.backend.sim.advanceCell({ dt });
      this.failing = false;
      if (!this.stopped) this.opts.onAdvanced(result);
    } catch (err) {
      if (!this.backend.isUp || (err as { status?: unknown }).status === 503) {
        // down (or restarting): no calls until it is up again
        this.paused = true;
        return;
      }
      if (!this.failing) this.opts.onError?.(err);
      this.failing = true;
    }
  }
}
