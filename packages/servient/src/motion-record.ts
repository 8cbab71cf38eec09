/**
 * What a twin knows of its own motion, owned by the twin (`Twin.motion`) and changed only through these
 * methods: whether a move holds the twin (`begin`/`end`), the backend motion it is running (`start`, then
 * `record` per streamed state), whether that motion's collision was announced, and while a command is
 * relayed to the physical robot, the simulated states it should follow (`relayStart`/`relayEnd`).
 *
 * The motion and relay sessions and the twin's own notifications change it; the follower, the divergence
 * and the safety monitor only read it.
 */
import type { Vec3 } from "@robwot/core";

/** A state of the twin's last simulated motion: simulated time (s), joints, end-effector position (virtual frame). */
export interface TrajectoryState {
  time: number;
  q: number[];
  position: Vec3;
  /** a program's step */
  step?: number;
}

/** How far the backend's motion has come: its simulated time and planned duration (s), a program's step. */
export interface MotionProgress {
  time: number;
  planned: number;
  step?: number;
}

/** A command relayed to the physical robot: the simulated states (time from the first) and when it was sent (ms). */
export interface RelayedMotion {
  states: TrajectoryState[];
  sentAt: number;
}

export class MotionRecord {
  private held = false;
  private endedAt = 0;
  private collided = false;
  private current: MotionProgress | null = null;
  private states: TrajectoryState[] | null = null;
  private relaying: RelayedMotion | null = null;

  /** true from the moment a move is accepted for validation until it ends */
  get busy(): boolean {
    return this.held;
  }

  /** when the last move ended (ms, Date.now()): a reading of the physical robot asked for before that may
   *  show it on the way there */
  get idleSince(): number {
    return this.endedAt;
  }

  /** the motion streamed by the backend since the last one started; null until its first state */
  get progress(): MotionProgress | null {
    return this.current;
  }

  /** the states of the last motion started, from the state it started in (empty before any) */
  get trajectory(): readonly TrajectoryState[] {
    return this.states ?? [];
  }

  /** while a command is relayed to the physical robot: what it should do, and since when */
  get relayed(): RelayedMotion | null {
    return this.relaying;
  }

  /** Takes the twin for a move; false when a move already holds it (the twin is never taken twice). */
  begin(): boolean {
    if (this.held) return false;
    this.held = true;
    return true;
  }

  /** The move that held the twin ended at `now` (ms). */
  end(now: number): void {
    this.held = false;
    this.endedAt = now;
  }

  /** A backend motion is sent from state `from`: its streamed states are recorded from here on. */
  start(from: TrajectoryState): void {
    this.collided = false;
    this.current = null;
    this.states = [from];
  }

  /** A state the backend streamed (every `robot.state`, whether a move of this servient sent the motion or not). */
  record(state: TrajectoryState, planned: number): void {
    this.states?.push(state);
    this.current = { time: state.time, planned, ...(state.step !== undefined ? { step: state.step } : {}) };
  }

  /** Whether the current motion's collision is still to be announced; true once per motion. */
  firstCollision(): boolean {
    if (this.collided) return false;
    this.collided = true;
    return true;
  }

  /** A command goes to the physical robot at `sentAt` (ms) to run `states` (their time counted from the first). */
  relayStart(states: readonly TrajectoryState[], sentAt: number): void {
    const t0 = states[0]?.time ?? 0;
    this.relaying = { states: states.map((s) => ({ ...s, time: s.time - t0 })), sentAt };
  }

  /** The relayed command was answered, failed or was abandoned. */
  relayEnd(): void {
    this.relaying = null;
  }
}
