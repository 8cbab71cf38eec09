/**
 * One twin's moves from acceptance to end: the pending move, busy, stop and cancel, and every write of
 * the motion status a move makes (one mapping from a motion's outcome to `lastError`).
 *
 * One move at a time: a move while another holds the twin answers 409 `E_BUSY`, and the twin is taken
 * before validation starts. A stop always wins: from its acceptance a move is a `PendingMove` that `stop`
 * cancels, so a move stopped before its motion was sent answers `stopped` without moving; one stopped
 * during its motion is stopped by the backend (`robot.stop` follows `robot.move` on the same ordered
 * connection, so it cannot overtake it); one stopped while the physical robot ran it answers `stopped`,
 * never `reached` (`stopWins`). A stop is never refused: with the backend down or hung its simulation
 * part reports the failure within `STOP_DEADLINE_MS`, and the physical robot's stop is sent first,
 * waiting on nothing.
 */
import type { MoveResult } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import type { MotionStatus, RelayedMoveOutput } from "@robwot/core";
import { ServientError } from "./errors.js";
import { STOP_DEADLINE_MS, type PhysicalStopReport } from "./relay.js";
import type { Twin } from "./twin.js";

/** The part of the backend supervisor a motion session calls. */
export type MotionBackend = Pick<BackendSupervisor, "isUp" | "sim">;

/** A move from its acceptance to its end. */
export interface PendingMove {
  /** set by `stop` (or a cancel of its asynchronous invocation) */
  readonly cancelled: boolean;
  /** settles once the move is cancelled and the stop of the physical robot given with it has settled:
   *  a relayed command's answer is not awaited past it */
  readonly whenCancelled: Promise<void>;
  cancel(done?: Promise<unknown>): void;
}

/** What an asynchronous invocation (`action-status.ts`) sees of its move once accepted. */
export interface MoveHandle {
  /** "pending" (validation, IK, path planning) until the backend streams the motion, then "running" */
  phase(): "pending" | "running";
  /** share of the planned motion done: simulated time / planned duration of the backend's path */
  progress(): number;
  /** the stop path (`stop`) for this move only: nothing once it has ended */
  cancel(): Promise<void>;
  /** a program's: the index of the step running (undefined before its motion starts, and for a move) */
  step(): number | undefined;
}

/** Called when a move is accepted (busy taken), before it is validated. */
export type MoveWatch = (handle: MoveHandle) => void;

/** The answer of `stop`: both outcomes, the physical robot's only with `--relay`. */
export interface StopReport {
  /** a move was pending, or the simulation or the physical robot stopped one */
  stopped: boolean;
  simulation: { ok: boolean; error?: string };
  physical?: { ok: boolean; attempts: number; error?: string };
}

/** What a backend motion call answers that the session reads. */
type MotionAnswer = { status: string; contacts: MoveResult["contacts"]; positions: number[] };

const errorMessage = (err: unknown): string => (err instanceof Error ? err.message : String(err));

/** `lastError` after a motion ended with `status` (a program's names the step it ended in); null when it reached. */
export function outcomeError(status: string, step?: number): MotionStatus["lastError"] | null {
  const where = step === undefined ? null : `in step ${step}`;
  if (status === "collision") return { code: "E_COLLISION", message: where ? `program stopped by a collision ${where}` : "motion stopped by a collision" };
  if (status === "stopped") return { code: "E_STOPPED", message: where ? `program stopped ${where}` : "motion stopped before reaching the target" };
  return null;
}

export class MotionSession {
  private pending: PendingMove | null = null;
  /** the moves whose backend motion has been sent */
  private readonly sent = new WeakSet<PendingMove>();

  constructor(
    private readonly backend: MotionBackend,
    private readonly twin: Twin,
    /** the physical robot's stop, sent at once and retried (`Relay.stop`); null without `--relay` */
    private readonly stopPhysical: (() => Promise<PhysicalStopReport>) | null,
  ) {}

  /** The move holding the twin, if any. */
  get current(): PendingMove | null {
    return this.pending;
  }

  /** Runs `run` as the twin's one move: refused with 409 `E_BUSY` while another holds the twin. */
  async guarded<T>(watch: MoveWatch | undefined, run: (move: PendingMove) => Promise<T>): Promise<T> {
    const motion = this.twin.motion;
    if (!motion.begin()) {
      throw new ServientError(409, "E_BUSY", `${this.twin.slug} is already moving; call stop first or wait for the motion to end`, {
        thing: this.twin.slug,
        state: this.twin.status.state,
      });
    }
    const move = pendingMove();
    this.pending = move;
    watch?.(this.handle(move));
    try {
      return await run(move);
    } finally {
      this.pending = null;
      motion.end(Date.now());
    }
  }

  private handle(move: PendingMove): MoveHandle {
    const progress = () => (this.sent.has(move) ? this.twin.motion.progress : null);
    return {
      phase: () => (progress() ? "running" : "pending"),
      progress: () => {
        const m = progress();
        if (!m) return 0;
        return m.planned > 0 ? Math.min(1, Math.max(0, m.time / m.planned)) : 1;
      },
      cancel: async () => {
        if (this.pending === move) await this.stop();
      },
      step: () => progress()?.step,
    };
  }

  /**
   * One backend motion call for `move` (a move's or a program's): the twin is "moving" while it
   * runs; a refused plan (`E_REJECTED`) is answered as `refuse` makes it (422) with the twin's state as
   * before, any other failure leaves the twin "stopped"; a collision emits the collision event once.
   */
  async motion<T extends MotionAnswer>(move: PendingMove, call: () => Promise<T>, refuse: (e: ServientError) => ServientError): Promise<T> {
    const twin = this.twin;
    const before = twin.status.state;
    twin.setStatus({ state: "moving", lastError: null });
    // the states of this motion follow the request on the same ordered connection; they are recorded (from
    // the state it starts in) as what a relay of it should make the physical robot do
    twin.motion.start({ time: 0, q: [...twin.q], position: [...twin.position] });
    this.sent.add(move);
    let res: T;
    try {
      res = await call();
    } catch (err) {
      const e = err instanceof ServientError ? err : new ServientError(500, "E_INTERNAL", String(err));
      if (e.code === "E_REJECTED") {
        const rejected = refuse(e);
        twin.setStatus({ state: before === "moving" ? "idle" : before, lastError: { code: rejected.code, message: rejected.message } });
        throw rejected;
      }
      twin.setStatus({ state: "stopped", lastError: { code: e.code, message: e.message } });
      throw e;
    }
    if (res.status === "collision") twin.onCollision(res.contacts, res.positions);
    return res;
  }

  /** The status after a motion ended with `status` (a program's in `step`), its result the last one. */
  ended(status: RelayedMoveOutput["status"], lastResult: RelayedMoveOutput, step?: number): void {
    this.twin.setStatus({ state: status === "reached" ? "idle" : status, lastError: outcomeError(status, step), lastResult });
  }

  /** The answer of a move stopped before its motion started: the twin has not moved. */
  stoppedBeforeStart(): RelayedMoveOutput {
    const twin = this.twin;
    const pose = twin.realPose();
    const result: RelayedMoveOutput = { status: "stopped", joints: twin.jointsRecord(), position: pose.position, orientation: pose.orientation, duration: 0 };
    twin.setStatus({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped before the motion started" }, lastResult: result });
    return result;
  }

  /** A move or program stopped while the physical robot ran it answers `stopped`, never `reached`. */
  stopWins(move: PendingMove, out: { status: string }): void {
    if (!move.cancelled) return;
    out.status = "stopped";
    this.twin.setStatus({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped while the physical robot ran the command" } });
  }

  /**
   * Cancels the pending move (whatever stage it is in) and stops the backend's motion and the physical
   * robot at once, neither waiting on the other. Never refused: with the backend down or hung the
   * simulation part reports its failure (after at most `STOP_DEADLINE_MS`), the physical stop is still
   * sent and retried.
   */
  async stop(): Promise<StopReport> {
    const move = this.pending;
    // the physical robot first: its stop is on its way before anything waits on the simulation
    const physical = this.stopPhysical?.() ?? null;
    move?.cancel(physical ?? undefined);
    const [sim, phys] = await Promise.all([this.stopSimulation(), physical]);
    const out: StopReport = {
      stopped: move !== null || sim.stopped || (phys?.ok === true && phys.stopped),
      simulation: sim.error === undefined ? { ok: sim.ok } : { ok: sim.ok, error: sim.error },
    };
    if (phys) out.physical = phys.error === undefined ? { ok: phys.ok, attempts: phys.attempts } : { ok: phys.ok, attempts: phys.attempts, error: phys.error };
    if (phys && !phys.ok) this.twin.setStatus({ lastError: { code: "E_RELAY", message: `stop not confirmed by the physical robot: ${phys.error}` } });
    return out;
  }

  /** The simulation's part of a stop: bounded by `STOP_DEADLINE_MS` (a hung backend is the heartbeat's to end). */
  private async stopSimulation(): Promise<{ ok: boolean; stopped: boolean; error?: string }> {
    if (!this.backend.isUp) return { ok: false, stopped: false, error: "simulation backend down (restarting): a motion in flight ended with it" };
    let timer: NodeJS.Timeout | undefined;
    const late = new Promise<never>((_, reject) => {
      timer = setTimeout(() => reject(new Error(`the simulation backend did not confirm the stop within ${STOP_DEADLINE_MS} ms`)), STOP_DEADLINE_MS);
    });
    try {
      const r = await Promise.race([this.backend.sim.stop({ robot: this.twin.robotId }), late]);
      return { ok: true, stopped: r.stopped };
    } catch (err) {
      return { ok: false, stopped: false, error: errorMessage(err) };
    } finally {
      clearTimeout(timer);
    }
  }
}

function pendingMove(): PendingMove {
  let settle = (): void => undefined;
  const whenCancelled = new Promise<void>((resolve) => (settle = resolve));
  const move = {
    cancelled: false,
    whenCancelled,
    cancel: (done: Promise<unknown> = Promise.resolve()) => {
      move.cancelled = true;
      void done.finally(settle);
    },
  };
  return move;
}
