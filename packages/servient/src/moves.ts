/**
 * Move actions, composed from their jobs: the input parsed once (`move-input.ts`), the move held, stopped
 * and its status written by the twin's motion session (`motion-session.ts`), the backend planning and
 * running it (a move = one `robot.move`, a program = one `program.run`: simulation in the loop), and with
 * `--relay` the completed motion relayed to the physical robot (`relay-session.ts`).
 *
 * A move while the twin is moving answers 409 `E_BUSY`; a rejected target 422 `E_REJECTED` with the
 * validation report in `details`; the twin does not move in either case. A stop always wins, at every
 * stage: before the backend call, during the motion, while the physical robot runs the command.
 */
import type { PlanChecks } from "@robwot/sim-client";
import type { RelayedMoveOutput, ValidationReport } from "@robwot/core";
import type { BackendSupervisor } from "@robwot/sim-client";
import { ServientError } from "./errors.js";
import { detourLegs, jointLeg, parseCartesianMove, parseJointMove, parseProgram, type CartesianInput, type JointInput, type ProgramInput, type RelayLeg } from "./move-input.js";
import { MotionSession, type MotionBackend, type MoveWatch, type PendingMove, type StopReport } from "./motion-session.js";
import type { Relay } from "./relay.js";
import { RelaySession, type DownSignal, type ProgramRelayReport } from "./relay-session.js";
import type { Twin } from "./twin.js";
import { report, staticChecks, validateCartesian, validateJoints, type PoseTarget } from "./validation.js";
import type { WorkspaceChecks } from "./workspace-checks.js";

export type { RelayedMoveOutput };
export type { CartesianInput, JointInput, ProgramInput } from "./move-input.js";
export type { MoveHandle, MoveWatch, StopReport } from "./motion-session.js";
export { RELAY_MOVE_DEADLINE } from "./relay-session.js";

/** runProgram's answer (`programRunResultSchema`). */
export interface ProgramRunResult {
  status: RelayedMoveOutput["status"];
  step: number;
  joints: Record<string, number>;
  position: RelayedMoveOutput["position"];
  orientation: RelayedMoveOutput["orientation"];
  duration: number;
  cycleTime: number;
  relay?: ProgramRelayReport;
}

export interface ProgramReport {
  valid: boolean;
  /** absent when every step passes */
  firstFailingStep?: number;
  cycleTime: number;
  steps: { step: number; ok: boolean; reasons: string[]; duration: number; planned?: string; blended?: boolean; holding?: string }[];
  trajectory: { rate: number; names: string[]; positions: number[][] };
}

/** The part of the backend supervisor the moves use. */
export type MoveBackend = MotionBackend & DownSignal;

export class Mover {
  private readonly session: MotionSession;
  private readonly relays: RelaySession | null;

  constructor(
    private readonly backend: MoveBackend,
    private readonly twin: Twin,
    private readonly ws: WorkspaceChecks | null,
    private readonly realtime: number,
    relay: Relay | null,
  ) {
    this.relays = relay ? new RelaySession(relay, twin, backend) : null;
    const relays = this.relays;
    this.session = new MotionSession(backend, twin, relays ? () => relays.stopNow() : null);
  }

  async validateJoints(input: JointInput): Promise<ValidationReport> {
    const m = parseJointMove(this.twin, input);
    return validateJoints(this.backend, this.twin, m.q, m.speed);
  }

  async validateCartesian(input: CartesianInput): Promise<ValidationReport> {
    const m = parseCartesianMove(this.twin, input);
    return validateCartesian(this.backend, this.twin, this.ws, m.target, m.speed);
  }

  /** A program's steps planned by the backend one after the other (nothing moves); Cartesian steps in the
   * frame of the TD (real with a calibration), like validateCartesianPosition's. */
  async validateProgram(input: ProgramInput): Promise<ProgramReport> {
    const plan = await this.backend.sim.planProgram({ robot: this.twin.robotId, steps: parseProgram(this.twin, input).sim });
    return programReport(plan);
  }

  async moveJoints(input: JointInput, watch?: MoveWatch): Promise<RelayedMoveOutput> {
    const m = parseJointMove(this.twin, input);
    return this.session.guarded(watch, async (move) => {
      const { result, detour } = await this.execute(move, { target: m.q }, m.speed, null);
      await this.relayed(move, result, () => [...detourLegs(this.twin, detour, m.speed), jointLeg(this.twin, m.q, m.speed)]);
      return result;
    });
  }

  async moveCartesian(input: CartesianInput, watch?: MoveWatch): Promise<RelayedMoveOutput> {
    const m = parseCartesianMove(this.twin, input);
    return this.session.guarded(watch, async (move) => {
      const { result, detour } = await this.execute(move, m.target, m.speed, staticChecks(this.ws, m.target.position));
      const p = result.position;
      result.positionError = Math.hypot(p.x - m.real[0], p.y - m.real[1], p.z - m.real[2]);
      // after a detour the last leg is the joint target the twin reached: the physical robot's own IK
      // could pick another solution for the pose, on a path nobody checked
      await this.relayed(move, result, () => [...detourLegs(this.twin, detour, m.speed), detour.length > 0 ? jointLeg(this.twin, this.twin.q, m.speed) : m.leg]);
      return result;
    });
  }

  /**
   * Runs a program: the backend plans it as validateProgram does (a refused step answers 422
   * `E_REJECTED` with the report in `details.program`; nothing moves) and runs its timed states as one
   * motion (a stop or cancel ends it at once). With `--relay`, once the simulation has run every step,
   * the physical robot gets them one after the other as the move actions relay theirs, each awaited
   * within its own deadline; the first that fails ends the relay and the report says which.
   */
  async runProgram(input: ProgramInput, watch?: MoveWatch): Promise<ProgramRunResult> {
    const program = parseProgram(this.twin, input);
    return this.session.guarded(watch, async (move) => {
      const twin = this.twin;
      if (move.cancelled) {
        const r = this.session.stoppedBeforeStart();
        return { status: r.status, step: 0, joints: r.joints, position: r.position, orientation: r.orientation, duration: 0, cycleTime: 0 };
      }
      const res = await this.session.motion(
        move,
        () => this.backend.sim.runProgram({ robot: twin.robotId, steps: program.sim, realtime: this.realtime }),
        (e) => {
          const reasons = (e.details.reasons ?? []) as string[];
          const plan = e.details.program as Parameters<typeof programReport>[0] | undefined;
          return new ServientError(422, "E_REJECTED", `program rejected by validation: ${reasons.join("; ")}`, { reasons, ...(plan ? { program: programReport(plan) } : {}) });
        },
      );
      const pose = twin.realPose();
      const motion: RelayedMoveOutput = { status: res.status, joints: twin.jointsRecord(res.positions), position: pose.position, orientation: pose.orientation, duration: res.duration };
      const out: ProgramRunResult = { status: res.status, step: res.step, joints: motion.joints, position: pose.position, orientation: pose.orientation, duration: res.duration, cycleTime: res.program?.cycleTime ?? 0 };
      this.session.ended(res.status, motion, res.step);
      // a stop that came after the simulated motion ended still keeps the steps from the physical robot
      if (res.status === "reached" && this.relays && !move.cancelled) {
        out.relay = await this.relays.program(move, program.legs, (res.program?.steps ?? []).map((s) => s.duration));
        this.session.stopWins(move, out);
      }
      return out;
    });
  }

  /** Runs `run` as the twin's one motion (409 `E_BUSY` while another holds the twin; a stop cancels it:
   *  `cancelled()` says so). The gripper's opening and closing (`grip.ts`). */
  exclusive<T>(run: (cancelled: () => boolean) => Promise<T>, watch?: MoveWatch): Promise<T> {
    return this.session.guarded(watch, (move) => run(() => move.cancelled));
  }

  /** Cancels the pending move and stops the simulation and the physical robot at once (`MotionSession.stop`). */
  stop(): Promise<StopReport> {
    return this.session.stop();
  }

  /**
   * Servient shutdown: cancels the pending move and, when a relayed command may be running on the
   * physical robot, stops it there (retried until it answers or the stop deadline passes).
   */
  async shutdown(): Promise<void> {
    const move = this.session.current;
    if (!move) return;
    const physical = this.relays?.shutdown();
    move.cancel(physical);
    await physical;
  }

  /** A move the simulation completed, relayed as `legs` unless a stop came first (even after its motion ended). */
  private async relayed(move: PendingMove, result: RelayedMoveOutput, legs: () => RelayLeg[]): Promise<void> {
    if (result.status !== "reached" || !this.relays || move.cancelled) return;
    result.relay = await this.relays.move(move, legs(), result.duration);
    this.session.stopWins(move, result);
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
  ): Promise<{ result: RelayedMoveOutput; detour: number[][] }> {
    if (move.cancelled) return { result: this.session.stoppedBeforeStart(), detour: [] };
    const twin = this.twin;
    // the twin's joints and pose are already those of the motion's end: the backend sends its final
    // robot.state (applied by Twin.onState) before it answers the move
    // relayed, a detour runs on the physical robot as one joint move per leg, at rest between them: the
    // twin runs it so, or the physical robot's divergence from it would only measure the smoothing
    const detourRun = this.relays ? { detour: "stops" as const } : {};
    const res = await this.session.motion(
      move,
      () => this.backend.sim.move({ robot: twin.robotId, ...target, speed, realtime: this.realtime, ...detourRun }),
      (e) => {
        const verdict = report({ valid: false, reasons: (e.details.reasons ?? []) as string[], checks: (e.details.checks ?? {}) as PlanChecks }, statics ?? undefined);
        return new ServientError(422, "E_REJECTED", `target rejected by validation: ${verdict.reasons.join("; ")}`, { reasons: verdict.reasons, checks: verdict.checks });
      },
    );
    const pose = twin.realPose();
    const result: RelayedMoveOutput = {
      status: res.status,
      joints: twin.jointsRecord(res.positions),
      position: pose.position,
      orientation: pose.orientation,
      duration: res.duration,
      path: res.plan?.checks.path?.planned ?? "straight",
    };
    this.session.ended(res.status, result);
    return { result, detour: result.path === "detour" ? (res.plan?.via ?? []) : [] };
  }
}

/** The twin's program report (`programReportSchema`) from the backend's plan. */
function programReport(plan: Awaited<ReturnType<BackendSupervisor["sim"]["planProgram"]>>): ProgramReport {
  return {
    valid: plan.valid,
    ...(plan.firstFailingStep !== null ? { firstFailingStep: plan.firstFailingStep } : {}),
    cycleTime: plan.cycleTime,
    steps: plan.steps.map((s) => ({ step: s.step, ok: s.ok, reasons: s.reasons, duration: s.duration, ...(s.planned ? { planned: s.planned } : {}), ...(s.blended ? { blended: true } : {}), ...(typeof s.holding === "string" ? { holding: s.holding } : {}) })),
    trajectory: { rate: plan.trajectory.rate, names: plan.trajectory.names, positions: plan.trajectory.positions },
  };
}
