/**
 * Move actions: validate (simulation in the loop), then run `robot.move` on the backend, keep the
 * twin's state and motion status current, relay to the physical robot when configured.
 * A move while the twin is moving answers 409 `E_BUSY`; a rejected target 422 `E_REJECTED` with the
 * validation report in `details`; the twin does not move in either case.
 *
 * A stop always wins: from the moment a move is accepted (before validation, IK and the path check)
 * it holds a `PendingMove`; `stop` cancels it, so a move stopped before its motion started answers
 * `status: "stopped"` without moving, and one stopped during its motion is stopped by the backend
 * (`robot.stop` follows `robot.move` on the same ordered connection, so it cannot overtake it).
 *
 * The physical robot (`--relay`) gets a command only after the simulated motion has reached its
 * target, so a move the simulation ends early (stop, collision, backend down) never reaches it. From
 * the moment the command is relayed until the physical Thing answers, every path that ends the move
 * early stops the physical robot: `stop` (its physical part is sent first and never waits on the
 * simulation), an asynchronous move cancelled, the backend going down, the relayed move's deadline,
 * and servient shutdown (`shutdown`).
 */
import type { MoveResult as BackendMoveResult, PlanChecks, ProgramSteps } from "@robwot/sim-client";
import { MIN_QUATERNION_NORM, MIN_SPEED, type Quaternion, type RelayedMoveResult, type ValidationReport, vec, type Vec3 } from "@robwot/core";
import type { BackendSupervisor } from "@robwot/sim-client";
import { badInput, ServientError } from "./errors.js";
import { answered, STOP_DEADLINE_MS, type PhysicalStopReport, type Relay, type RelayReport } from "./relay.js";
import type { Twin } from "./twin.js";
import { poseTarget, report, staticChecks, validateCartesian, validateJoints, type PoseTarget } from "./validation.js";
import type { WorkspaceChecks } from "./workspace-checks.js";

export type { RelayedMoveResult };

/** One command to the physical robot: a move action of the twin's TD and its input. */
interface RelayLeg {
  action: string;
  input: unknown;
}

export interface JointInput {
  joints: Record<string, unknown>;
  speed?: number;
}

export interface CartesianInput {
  x: number;
  y: number;
  z: number;
  orientation?: Quaternion;
  speed?: number;
  /** "ptp" (default), "lin" or "circ" (the schema allows no other) */
  motion?: string;
  /** circ: a point of the arc, in the frame of x, y, z */
  via?: { x: number; y: number; z: number };
}

export interface ProgramInput {
  steps: (Partial<CartesianInput> & { joints?: Record<string, unknown>; acceleration?: number; tcpSpeed?: number; blend?: number })[];
}

/** runProgram's answer (`programRunResultSchema`). */
export interface ProgramRunResult {
  status: RelayedMoveResult["status"];
  step: number;
  joints: Record<string, number>;
  position: RelayedMoveResult["position"];
  orientation: RelayedMoveResult["orientation"];
  duration: number;
  cycleTime: number;
  relay?: { ok: boolean; steps: { step: number; ok: boolean; error?: string }[]; error?: string };
}

export interface ProgramReport {
  valid: boolean;
  /** absent when every step passes */
  firstFailingStep?: number;
  cycleTime: number;
  steps: { step: number; ok: boolean; reasons: string[]; duration: number; planned?: string; blended?: boolean }[];
  trajectory: { rate: number; names: string[]; positions: number[][] };
}

/** The via point of a circ in the frame of x, y, z; the schema checks its numbers. */
function viaOf(input: CartesianInput): Vec3 | undefined {
  return input.via === undefined ? undefined : [input.via.x, input.via.y, input.via.z];
}

export function speedOf(input: { speed?: unknown }): number {
  const s = input.speed ?? 1;
  if (typeof s !== "number" || !Number.isFinite(s) || s < MIN_SPEED || s > 1) {
    throw badInput(`speed must be a number in [${MIN_SPEED}, 1], got ${JSON.stringify(s)}`, { param: "speed", value: s ?? null });
  }
  return s;
}

export function cartesianTarget(input: CartesianInput): { real: Vec3; orientation?: Quaternion } {
  for (const k of ["x", "y", "z"] as const) {
    if (typeof input[k] !== "number" || !Number.isFinite(input[k])) {
      throw badInput(`${k} must be a finite number (m), got ${JSON.stringify(input[k])}`, { param: k, value: input[k] ?? null });
    }
  }
  const o = input.orientation;
  if (o !== undefined) {
    const n = Math.hypot(o.x, o.y, o.z, o.w);
    if (![o.x, o.y, o.z, o.w].every((v) => typeof v === "number" && Number.isFinite(v)) || n < MIN_QUATERNION_NORM) {
      throw badInput(`orientation must be a quaternion {x, y, z, w} of norm >= ${MIN_QUATERNION_NORM}`, { param: "orientation", value: o });
    }
    return { real: vec(input), orientation: { x: o.x / n, y: o.y / n, z: o.z / n, w: o.w / n } };
  }
  return { real: vec(input) };
}

/** A move from its acceptance to its end; `cancelled` is set by `stop`, `sent` once `robot.move` is. */
interface PendingMove {
  cancelled: boolean;
  /** settles once `stop` has cancelled the move and `done` (its stop of the physical robot) has settled:
   *  a relayed command's answer is not awaited past it */
  whenCancelled: Promise<void>;
  cancel(done?: Promise<unknown>): void;
  sent: boolean;
  /** set while the command is relayed to the physical robot and not yet answered */
  relaying: boolean;
  /** why the twin stopped the physical robot during this move's relay (not set by `stop`) */
  physicalStop?: { reason: string; report: Promise<PhysicalStopReport> };
}

/** The answer of `stop`: both outcomes, the physical robot's only with `--relay`. */
export interface StopReport {
  /** a move was pending, or the simulation or the physical robot stopped one */
  stopped: boolean;
  simulation: { ok: boolean; error?: string };
  physical?: { ok: boolean; attempts: number; error?: string };
}

/**
 * A relayed move that the physical robot has not answered within `factor` times the simulated motion's
 * duration plus `marginMs` is stopped there: the physical robot is expected to move like its twin.
 */
export const RELAY_MOVE_DEADLINE = { factor: 3, marginMs: 10_000 };

const errorMessage = (err: unknown): string => (err instanceof Error ? err.message : String(err));

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

export class Mover {
  private pending: PendingMove | null = null;

  constructor(
    private readonly backend: BackendSupervisor,
    private readonly twin: Twin,
    private readonly ws: WorkspaceChecks | null,
    private readonly realtime: number,
    private readonly relay: Relay | null,
  ) {
    // the simulation that validated a relayed command is gone: the physical robot does not run on unwatched
    backend.on("down", (reason) => {
      if (this.pending?.relaying) this.stopPhysical(this.pending, `simulation backend down: ${reason}`);
    });
  }

  async validateJoints(input: JointInput): Promise<ValidationReport> {
    const q = this.twin.jointsVector(input.joints);
    return validateJoints(this.backend, this.twin, q, speedOf(input));
  }

  async validateCartesian(input: CartesianInput): Promise<ValidationReport> {
    const t = cartesianTarget(input);
    return validateCartesian(this.backend, this.twin, this.ws, poseTarget(this.twin, t.real, t.orientation, input.motion, viaOf(input)), speedOf(input));
  }

  /** A program's steps planned by the backend one after the other (nothing moves); Cartesian steps in the
   * frame of the TD (real with a calibration), like validateCartesianPosition's. */
  async validateProgram(input: ProgramInput): Promise<ProgramReport> {
    const plan = await this.backend.sim.planProgram({ robot: this.twin.robotId, steps: this.programSteps(input).sim });
    return programReport(plan);
  }

  /**
   * Runs a program: the backend plans it as validateProgram does (a refused step answers 422
   * `E_REJECTED` with the report in `details.program`; nothing moves) and runs its timed states as one
   * motion (a stop or cancel ends it at once). With `--relay`, once the simulation has run every step,
   * the physical robot gets them one after the other as the move actions relay theirs, each awaited
   * within its own deadline; the first that fails ends the relay (the physical robot is stopped when it
   * did not answer) and the report says which.
   */
  async runProgram(input: ProgramInput, watch?: MoveWatch): Promise<ProgramRunResult> {
    const { sim, relay } = this.programSteps(input);
    return this.guarded(watch, async (move) => {
      const twin = this.twin;
      if (move.cancelled) {
        const r = this.cancelled();
        return { status: r.status, step: 0, joints: r.joints, position: r.position, orientation: r.orientation, duration: 0, cycleTime: 0 };
      }
      const res = await this.motion(
        move,
        () => this.backend.sim.runProgram({ robot: twin.robotId, steps: sim, realtime: this.realtime }),
        (e) => {
          const reasons = (e.details.reasons ?? []) as string[];
          const program = e.details.program as Parameters<typeof programReport>[0] | undefined;
          return new ServientError(422, "E_REJECTED", `program rejected by validation: ${reasons.join("; ")}`, {
            reasons,
            ...(program ? { program: programReport(program) } : {}),
          });
        },
      );
      const pose = twin.realPose();
      const out: ProgramRunResult = {
        status: res.status,
        step: res.step,
        joints: twin.jointsRecord(res.positions),
        position: pose.position,
        orientation: pose.orientation,
        duration: res.duration,
        cycleTime: res.program?.cycleTime ?? 0,
      };
      const lastError =
        res.status === "collision"
          ? { code: "E_COLLISION", message: `program stopped by a collision in step ${res.step}` }
          : res.status === "stopped"
            ? { code: "E_STOPPED", message: `program stopped in step ${res.step}` }
            : null;
      const { relay: _, cycleTime: __, step: ___, ...motion } = out;
      twin.setStatus({ state: res.status === "reached" ? "idle" : res.status, lastError, lastResult: motion });
      if (res.status === "reached" && this.relay && !move.cancelled) {
        const durations = (res.program?.steps ?? []).map((s) => s.duration);
        out.relay = await this.relayProgram(move, this.relay, relay, durations);
        this.stopWins(move, out);
      }
      return out;
    });
  }

  /** The steps of a program relayed one after the other, each like a move's (`relayMove`); stops at the first that fails. */
  private async relayProgram(move: PendingMove, relay: Relay, steps: { action: string; input: unknown }[], durations: number[]): Promise<NonNullable<ProgramRunResult["relay"]>> {
    const reports: { step: number; ok: boolean; error?: string }[] = [];
    for (const [k, step] of steps.entries()) {
      if (move.cancelled) return { ok: false, steps: reports, error: `stopped before step ${k}` };
      // the states of step k, from where the previous one ended
      const recorded = this.twin.trajectory ?? [];
      const mine = recorded.flatMap((s, i) => (s.step === k ? [i] : []));
      const states = mine.length === 0 ? [] : recorded.slice(Math.max(0, mine[0]! - 1), mine[mine.length - 1]! + 1);
      const r = await this.relayMove(move, relay, [step], durations[k] ?? 0, states);
      reports.push(r.ok ? { step: k, ok: true } : { step: k, ok: false, error: r.error ?? "failed" });
      if (!r.ok) return { ok: false, steps: reports, error: `step ${k}: ${r.error ?? "failed"}` };
    }
    return { ok: true, steps: reports };
  }

  /** A program's steps for the backend (joint vectors; Cartesian in the simulation's frame) and as the
   * physical robot's move actions take them (in the frame of the TD). */
  private programSteps(input: ProgramInput): { sim: ProgramSteps; relay: { action: string; input: unknown }[] } {
    const relay: { action: string; input: unknown }[] = [];
    const sim = input.steps.map((step, k) => {
      const speed = speedOf(step);
      // acceleration and tcpSpeed: the schema bounds them (the contract's Acceleration and TcpSpeed)
      const timing = {
        ...(step.acceleration !== undefined ? { acceleration: step.acceleration } : {}),
        ...(step.tcpSpeed !== undefined ? { tcpSpeed: step.tcpSpeed } : {}),
        ...(step.blend !== undefined ? { blend: step.blend } : {}),
      };
      const hasXyz = step.x !== undefined || step.y !== undefined || step.z !== undefined;
      if ((step.joints !== undefined) === hasXyz) {
        throw badInput(`steps[${k}]: give joints (a PTP step) or x, y, z, not ${hasXyz ? "both" : "neither"}`, { param: `steps[${k}]` });
      }
      if (step.joints !== undefined) {
        if (step.motion !== undefined && step.motion !== "ptp") throw badInput(`steps[${k}]: a joint target is a PTP step, not ${step.motion}`, { param: `steps[${k}].motion` });
        const q = this.twin.jointsVector(step.joints);
        relay.push({ action: "moveToJointPosition", input: { joints: this.twin.jointsRecord(q), speed } });
        return { target: q, speed, ...timing };
      }
      if ((step.via !== undefined) !== (step.motion === "circ")) throw badInput(`steps[${k}]: via goes with motion circ, and only with it`, { param: `steps[${k}].via` });
      const t = cartesianTarget(step as CartesianInput);
      const cmd: Record<string, unknown> = { x: t.real[0], y: t.real[1], z: t.real[2], speed };
      if (t.orientation) cmd.orientation = t.orientation;
      if (step.motion) cmd.motion = step.motion;
      if (step.via) cmd.via = step.via;
      relay.push({ action: "moveToCartesianPosition", input: cmd });
      return { ...poseTarget(this.twin, t.real, t.orientation, step.motion, viaOf(step as CartesianInput)), speed, ...timing };
    });
    return { sim: sim as ProgramSteps, relay };
  }

  async moveJoints(input: JointInput, watch?: MoveWatch): Promise<RelayedMoveResult> {
    const q = this.twin.jointsVector(input.joints);
    const speed = speedOf(input);
    return this.guarded(watch, async (move) => {
      const { result, detour } = await this.execute(move, { target: q }, speed, null);
      // a stop that came after the simulated motion ended still keeps the command from the physical robot
      if (result.status === "reached" && this.relay && !move.cancelled) {
        result.relay = await this.relayMove(move, this.relay, [...this.detourLegs(detour, speed), this.jointLeg(q, speed)], result.duration);
        this.stopWins(move, result);
      }
      return result;
    });
  }

  async moveCartesian(input: CartesianInput, watch?: MoveWatch): Promise<RelayedMoveResult> {
    const t = cartesianTarget(input);
    const speed = speedOf(input);
    const target = poseTarget(this.twin, t.real, t.orientation, input.motion, viaOf(input));
    return this.guarded(watch, async (move) => {
      const { result, detour } = await this.execute(move, target, speed, staticChecks(this.ws, target.position));
      const p = result.position;
      result.positionError = Math.hypot(p.x - t.real[0], p.y - t.real[1], p.z - t.real[2]);
      // a stop that came after the simulated motion ended still keeps the command from the physical robot
      if (result.status === "reached" && this.relay && !move.cancelled) {
        const cmd: Record<string, unknown> = { x: t.real[0], y: t.real[1], z: t.real[2], speed };
        if (t.orientation) cmd.orientation = t.orientation;
        if (target.motion) cmd.motion = target.motion;
        if (input.via) cmd.via = input.via;
        // after a detour the last leg is the joint target the twin reached: the physical robot's own IK
        // could pick another solution for the pose, on a path nobody checked
        const last = detour.length > 0 ? this.jointLeg(this.twin.q, speed) : { action: "moveToCartesianPosition", input: cmd };
        result.relay = await this.relayMove(move, this.relay, [...this.detourLegs(detour, speed), last], result.duration);
        this.stopWins(move, result);
      }
      return result;
    });
  }

  /**
   * Cancels the pending move (whatever stage it is in) and stops the backend's motion and the physical
   * robot at once, neither waiting on the other. Never refused: with the backend down or hung the
   * simulation part reports its failure (after at most `STOP_DEADLINE_MS`), the physical stop is still
   * sent and retried (`Relay.stop`).
   */
  async stop(): Promise<StopReport> {
    const move = this.pending;
    // the physical robot first: its stop is on its way before anything waits on the simulation
    const physical = this.relay ? this.relay.stop() : null;
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

  /**
   * Servient shutdown: cancels the pending move and, when a relayed command may be running on the
   * physical robot, stops it there (retried until it answers or the stop deadline passes).
   */
  async shutdown(): Promise<void> {
    const move = this.pending;
    if (!move) return;
    const physical = move.relaying ? this.stopPhysical(move, "servient shutting down").report : undefined;
    move.cancel(physical);
    await physical;
  }

  /** The simulation's part of a stop: bounded by `STOP_DEADLINE_MS` (a hung backend is the heartbeat's to end). */
  private async stopSimulation(): Promise<{ ok: boolean; stopped: boolean; error?: string }> {
    if (!this.backend.isUp) return { ok: false, stopped: false, error: "simulation backend down (restarting): a motion in flight ended with it" };
    let timer: NodeJS.Timeout | undefined;
    const late = new Promise<never>((_, reject) => {
      timer = setTimeout(() => reject(new Error(`the simulation backend did not confirm the stop within ${STOP_DEADLINE_MS} ms`)), STOP_DEADLINE_MS);
    });
    try {
      const r = await Promise.race([this.backend.sim.stop(this.twin.robotId), late]);
      return { ok: true, stopped: r.stopped };
    } catch (err) {
      return { ok: false, stopped: false, error: errorMessage(err) };
    } finally {
      clearTimeout(timer);
    }
  }

  /** Stops the physical robot for `move` once (later reasons reuse the first stop). */
  private stopPhysical(move: PendingMove, reason: string): { reason: string; report: Promise<PhysicalStopReport> } {
    if (!move.physicalStop && this.relay) {
      move.physicalStop = { reason, report: this.relay.stop() };
      this.twin.setStatus({ lastError: { code: "E_RELAY", message: `physical robot stopped: ${reason}` } });
    }
    return move.physicalStop ?? { reason, report: Promise.resolve({ ok: false, attempts: 0, stopped: false, error: "no relay" }) };
  }

  /** A joint move of the physical robot to `q`. */
  private jointLeg(q: readonly number[], speed: number): RelayLeg {
    return { action: "moveToJointPosition", input: { joints: this.twin.jointsRecord([...q]), speed } };
  }

  /** A detour's waypoints as joint moves: each leg is a straight joint-space segment the twin checked, as
   * a physical robot's joint move runs it; sent as one command, the target alone would go straight. */
  private detourLegs(detour: readonly number[][], speed: number): RelayLeg[] {
    return detour.map((q) => this.jointLeg(q, speed));
  }

  /**
   * Relays a move the simulation has completed, as one or more commands (a detour's legs) sent one after
   * the other, each once the previous one is answered, and waits for the physical robot's answers, at most
   * `RELAY_MOVE_DEADLINE` after the simulated duration in all; past it the physical robot is stopped. The
   * first leg that fails ends the relay. When the twin stopped the physical robot (backend down,
   * deadline) the report says why.
   */
  private async relayMove(move: PendingMove, relay: Relay, legs: RelayLeg[], duration: number, states = this.twin.trajectory ?? []): Promise<RelayReport> {
    const deadline = Date.now() + Math.ceil(duration * 1000 * RELAY_MOVE_DEADLINE.factor + RELAY_MOVE_DEADLINE.marginMs);
    move.relaying = true;
    // what the physical robot should do from now on: the simulated states, their time from the first
    const t0 = states[0]?.time ?? 0;
    this.twin.relayed = { states: states.map((s) => ({ ...s, time: s.time - t0 })), sentAt: Date.now() };
    let r: RelayReport = { ok: false, target: relay.url, action: legs[0]?.action ?? "", error: "nothing relayed" };
    try {
      for (const [k, leg] of legs.entries()) {
        if (move.cancelled) break;
        // a stop ends the relayed command's wait at once (its own stop to the physical robot is on its way)
        const stopped = move.whenCancelled.then((): RelayReport => ({ ok: false, target: relay.url, action: leg.action, error: "stopped" }));
        r = await Promise.race([relay.forward(leg.action, leg.input, Math.max(1, deadline - Date.now())), stopped]);
        if (legs.length > 1) r = { ...r, leg: k, legs: legs.length };
        if (!answered(r) && !move.cancelled) {
          // no answer in time, or the connection failed mid-command: the command may be running there
          this.stopPhysical(move, `relayed ${leg.action} without an answer (${r.error})`);
        }
        if (!r.ok) break;
      }
    } finally {
      move.relaying = false;
      this.twin.relayed = null;
    }
    const stop = move.physicalStop;
    if (stop) {
      const s = await stop.report;
      const how = s.ok ? `stop confirmed after ${s.attempts} attempt(s)` : `stop not confirmed: ${s.error}`;
      r = { ...r, ok: false, error: `stopped by the twin (${stop.reason}); ${how}` };
    }
    this.reportRelay(r);
    return r;
  }

  /** One move at a time per twin: the busy flag and the pending move are taken before validation starts. */
  private async guarded<T>(watch: MoveWatch | undefined, run: (move: PendingMove) => Promise<T>): Promise<T> {
    if (this.twin.busy) {
      throw new ServientError(409, "E_BUSY", `${this.twin.slug} is already moving; call stop first or wait for the motion to end`, {
        thing: this.twin.slug,
        state: this.twin.status.state,
      });
    }
    this.twin.busy = true;
    let cancelled = (): void => undefined;
    const move: PendingMove = {
      cancelled: false,
      whenCancelled: new Promise<void>((resolve) => (cancelled = resolve)),
      cancel: (done = Promise.resolve()) => {
        move.cancelled = true;
        void done.finally(cancelled);
      },
      sent: false,
      relaying: false,
    };
    this.pending = move;
    watch?.(this.handle(move));
    try {
      return await run(move);
    } finally {
      this.pending = null;
      this.twin.busy = false;
      this.twin.idleSince = Date.now();
    }
  }

  private handle(move: PendingMove): MoveHandle {
    const motion = (): Twin["motion"] => (move.sent ? this.twin.motion : null);
    return {
      phase: () => (motion() ? "running" : "pending"),
      progress: () => {
        const m = motion();
        if (!m) return 0;
        return m.planned > 0 ? Math.min(1, Math.max(0, m.time / m.planned)) : 1;
      },
      cancel: async () => {
        if (this.pending === move) await this.stop();
      },
      step: () => motion()?.step,
    };
  }

  /** The answer of a move stopped before its motion started: the twin has not moved. */
  private cancelled(): RelayedMoveResult {
    const twin = this.twin;
    const pose = twin.realPose();
    const result: RelayedMoveResult = { status: "stopped", joints: twin.jointsRecord(), position: pose.position, orientation: pose.orientation, duration: 0 };
    twin.setStatus({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped before the motion started" }, lastResult: result });
    return result;
  }

  /** A move or program stopped while the physical robot ran it answers `stopped`, never `reached`. */
  private stopWins(move: PendingMove, out: { status: string }): void {
    if (!move.cancelled) return;
    out.status = "stopped";
    this.twin.setStatus({ state: "stopped", lastError: { code: "E_STOPPED", message: "stopped while the physical robot ran the command" } });
  }

  private reportRelay(r: RelayReport): void {
    if (!r.ok) this.twin.setStatus({ lastError: { code: "E_RELAY", message: `relay to the physical robot failed: ${r.error}` } });
  }

  /**
   * One backend motion call for `move` (a move's or a program's): the twin is "moving" while it runs;
   * a refused plan (`E_REJECTED`) is answered as `refuse` makes it (422) with the twin's state as before,
   * any other failure leaves the twin "stopped"; a collision emits the collision event once.
   */
  private async motion<T extends { status: string; contacts: BackendMoveResult["contacts"]; positions: number[] }>(
    move: PendingMove,
    call: () => Promise<T>,
    refuse: (e: ServientError) => ServientError,
  ): Promise<T> {
    const twin = this.twin;
    const before = twin.status.state;
    twin.collisionSeen = false;
    twin.setStatus({ state: "moving", lastError: null });
    // the states of this motion follow the request on the same ordered connection; they are recorded (from
    // the state it starts in) as what a relay of it should make the physical robot do
    twin.motion = null;
    twin.trajectory = [{ time: 0, q: [...twin.q], position: [...twin.position] }];
    move.sent = true;
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
    if (res.status === "collision" && !twin.collisionSeen) twin.onCollision(res.contacts, res.positions);
    return res;
  }

  /**
   * The move as one backend operation (plan: limits, IK solutions, a collision-free path; then the
   * motion), unless a stop came first. A refused plan answers 422 `E_REJECTED` with its reasons and
   * checks (and the static checks of a Cartesian target beside them); the twin has not moved.
   */
  private async execute(
    move: PendingMove,
    target: { target: number[] } | PoseTarget,
    speed: number,
    statics: ReturnType<typeof staticChecks> | null,
  ): Promise<{ result: RelayedMoveResult; detour: number[][] }> {
    if (move.cancelled) return { result: this.cancelled(), detour: [] };
    const twin = this.twin;
    // the twin's joints and pose are already those of the motion's end: the backend sends its final
    // robot.state (applied by Twin.onState) before it answers the move
    const res = await this.motion(
      move,
      () => this.backend.sim.move({ robot: twin.robotId, ...target, speed, realtime: this.realtime }),
      (e) => {
        const verdict = report({ valid: false, reasons: (e.details.reasons ?? []) as string[], checks: (e.details.checks ?? {}) as PlanChecks }, statics ?? undefined);
        return new ServientError(422, "E_REJECTED", `target rejected by validation: ${verdict.reasons.join("; ")}`, {
          reasons: verdict.reasons,
          checks: verdict.checks,
        });
      },
    );
    const pose = twin.realPose();
    const result: RelayedMoveResult = {
      status: res.status,
      joints: twin.jointsRecord(res.positions),
      position: pose.position,
      orientation: pose.orientation,
      duration: res.duration,
      path: res.plan?.checks.path?.planned ?? "straight",
    };
    const state = res.status === "reached" ? "idle" : res.status;
    const lastError =
      res.status === "collision"
        ? { code: "E_COLLISION", message: "motion stopped by a collision" }
        : res.status === "stopped"
          ? { code: "E_STOPPED", message: "motion stopped before reaching the target" }
          : null;
    twin.setStatus({ state, lastError, lastResult: result });
    return { result, detour: result.path === "detour" ? (res.plan?.via ?? []) : [] };
  }
}

/** The twin's program report (`programReportSchema`) from the backend's plan. */
function programReport(plan: Awaited<ReturnType<BackendSupervisor["sim"]["planProgram"]>>): ProgramReport {
  return {
    valid: plan.valid,
    ...(plan.firstFailingStep !== null ? { firstFailingStep: plan.firstFailingStep } : {}),
    cycleTime: plan.cycleTime,
    steps: plan.steps.map((s) => ({ step: s.step, ok: s.ok, reasons: s.reasons, duration: s.duration, ...(s.planned ? { planned: s.planned } : {}), ...(s.blended ? { blended: true } : {}) })),
    trajectory: { rate: plan.trajectory.rate, names: plan.trajectory.names, positions: plan.trajectory.positions },
  };
}
