/**
 * One twin's live state: joint vector, end-effector pose (virtual frame), motion status and the
 * calibration frame map. Emits `joints`, `status` and `collision` for the /live stream and for
 * node-wot property observation.
 */
import { EventEmitter } from "node:events";
import { type CollisionEvent, type Contact, FrameMap, type MotionStatus, quat, type Quaternion, type RobotModelLike, tdContact, type Vec3, xyz, type Xyz } from "@robwot/core";
import type { PoseResult, RobotStateNotification } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import { badInput } from "./errors.js";
import type { TwinFolder } from "./twin-folder.js";

export interface LiveJoints {
  thing: string;
  type: "joints";
  time: number;
  joints: Record<string, number>;
  position: Xyz;
  orientation: Quaternion;
}

export interface TwinEvents {
  joints: [msg: LiveJoints];
  status: [status: MotionStatus];
  collision: [event: CollisionEvent];
  /** a new reading of the physical robot (serve --follow) */
  physical: [];
  /** the physical robot's divergence from the relayed motion passed the bound (serve --follow) */
  divergence: [event: DivergenceEvent];
  /** the safety monitor predicts a contact of the physical robot (serve --follow) */
  collisionImminent: [event: CollisionImminentEvent];
}

/** `collisionImminent` event: what the physical robot would touch within the horizon, and whether it was stopped. */
export interface CollisionImminentEvent {
  contacts: { a: unknown; b: unknown }[];
  /** s until the contact at the current joint velocity (0: already within the clearance) */
  in: number;
  joints: Record<string, number>;
  stopped: boolean;
  error?: string;
}

/** A state of the twin's last simulated motion: simulated time (s), joints, end-effector position (virtual frame). */
export interface TrajectoryState {
  time: number;
  q: number[];
  position: Vec3;
  /** a program's step */
  step?: number;
}

/** `divergence` event: how far the physical robot was from the relayed motion when it passed the bound. */
export interface DivergenceEvent {
  /** rad or m: the largest joint difference */
  joint: number;
  /** m: distance of the end effectors */
  tcp: number;
  /** s since the relayed command was sent */
  time: number;
  bound: number;
  joints: Record<string, number>;
  expected: Record<string, number>;
}

export class Twin extends EventEmitter<TwinEvents> {
  readonly slug: string;
  readonly robotId: string;
  readonly folder: TwinFolder;
  model: RobotModelLike | null = null;
  /** joint vector in `model.controllable` order (rad / m) */
  q: number[] = [];
  /** end-effector pose, virtual frame */
  position: Vec3 = [0, 0, 0];
  orientation: Quaternion = { x: 0, y: 0, z: 0, w: 1 };
  time = 0;
  status: MotionStatus = { state: "idle" };
  frames: FrameMap;
  /** true from the moment a move is accepted for validation until it ends */
  busy = false;
  /** when the last move ended (ms, Date.now()): a reading of the physical robot asked for before that may
   *  show it on the way there */
  idleSince = 0;
  /** set when a collision event was emitted for the current motion */
  collisionSeen = false;
  /** the motion streamed by the backend since the last move was sent (`robot.state`: simulated time and
   *  planned duration); null until its first state */
  motion: { time: number; planned: number; step?: number } | null = null;
  /** the states of the motion the backend streams, while a move records them (`Mover`: for the relay) */
  trajectory: TrajectoryState[] | null = null;
  /** while a move is relayed: its simulated states and when the command was sent (ms, Date.now()) */
  relayed: { states: TrajectoryState[]; sentAt: number } | null = null;
  /** `serve --follow`: the physical robot's state as `physicalState` reports it */
  physical: (() => object) | null = null;

  constructor(
    slug: string,
    folder: TwinFolder,
    private readonly backend: BackendSupervisor,
  ) {
    super();
    this.setMaxListeners(0);
    this.slug = slug;
    this.robotId = slug;
    this.folder = folder;
    this.frames = new FrameMap(folder.calibration);
  }

  get joints(): string[] {
    return this.model?.controllable ?? [];
  }

  jointsRecord(q: readonly number[] = this.q): Record<string, number> {
    const out: Record<string, number> = {};
    this.joints.forEach((name, i) => (out[name] = q[i] ?? 0));
    return out;
  }

  /** Joint record (all controllable joints required, no unknown ones) -> vector. */
  jointsVector(rec: Record<string, unknown>): number[] {
    const unknown = Object.keys(rec).filter((k) => !this.joints.includes(k));
    if (unknown.length > 0) {
      throw badInput(`unknown joint(s) ${unknown.join(", ")}; joints are ${this.joints.join(", ")}`, {
        unknown,
        available: this.joints,
      });
    }
    return this.joints.map((name) => {
      const v = rec[name];
      if (typeof v !== "number" || !Number.isFinite(v)) {
        throw badInput(`joint ${name}: expected a finite number, got ${JSON.stringify(v)}`, { joint: name, value: v ?? null });
      }
      return v;
    });
  }

  /** Cartesian pose in the real frame (identity when not calibrated). */
  realPose(position: Vec3 = this.position, orientation: Quaternion = this.orientation): { position: Xyz; orientation: Quaternion } {
    return { position: xyz(this.frames.pointToReal(position)), orientation: this.frames.quatToReal(orientation) };
  }

  liveJoints(): LiveJoints {
    const p = this.realPose();
    return { thing: this.slug, type: "joints", time: this.time, joints: this.jointsRecord(), ...p };
  }

  /** Updates the motion status; `lastError: null` clears the error (the field is then absent). */
  setStatus(patch: Partial<Omit<MotionStatus, "lastError">> & { lastError?: MotionStatus["lastError"] | null }): void {
    const { lastError, ...rest } = patch;
    const next: MotionStatus = { ...this.status, ...rest };
    if (lastError === null) delete next.lastError;
    else if (lastError !== undefined) next.lastError = lastError;
    this.status = next;
    this.emit("status", this.status);
  }

  applyPose(q: number[], fk: Pick<PoseResult, "position" | "orientation">): void {
    this.q = [...q];
    this.position = [fk.position[0] ?? 0, fk.position[1] ?? 0, fk.position[2] ?? 0];
    this.orientation = quat(fk.orientation);
    this.emit("joints", this.liveJoints());
  }

  /**
   * `robot.state` notification: joints and the end-effector pose of the same simulated instant (the
   * backend computes the pose with the state: no FK round trip per notification).
   */
  onState(params: RobotStateNotification): void {
    this.time = params.time;
    const position: Vec3 = [params.position[0] ?? 0, params.position[1] ?? 0, params.position[2] ?? 0];
    this.trajectory?.push({ time: params.time, q: [...params.positions], position, ...(params.step !== undefined ? { step: params.step } : {}) });
    this.motion = { time: params.time, planned: params.planned, ...(params.step !== undefined ? { step: params.step } : {}) };
    this.applyPose(params.positions, params);
  }

  /** A motion stopped on contact: emits the `collision` event once per motion. */
  onCollision(contacts: Contact[], positions: number[]): void {
    const ev = this.collisionEvent(contacts, positions);
    if (!ev || this.collisionSeen) return;
    this.collisionSeen = true;
    this.emit("collision", ev);
  }

  /** `robot.collision` notification -> the `collision` event (contact point in the real frame). */
  collisionEvent(contacts: Contact[], positions: number[]): CollisionEvent | null {
    const c = [...contacts].sort((a, b) => b.depth - a.depth)[0];
    if (!c) return null;
    return {
      pair: (({ a, b }) => ({ a, b }))(tdContact(c)),
      position: xyz(this.frames.pointToReal(c.position)),
      depth: c.depth,
      joints: this.jointsRecord(positions),
    };
  }
}
