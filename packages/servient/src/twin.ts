/**
 * One twin's live state: joint vector, end-effector pose (virtual frame), motion status and the
 * calibration frame map. Emits `joints`, `status` and `collision` for the /live stream and for
 * node-wot property observation.
 */
import { EventEmitter } from "node:events";
import { type CollisionEvent, type Contact, FrameMap, type MotionStatus, quat, type Quaternion, type RobotModelLike, tdContact, type Vec3, xyz, type Xyz } from "@robwot/core";
import type { PoseResult, RobotStateNotification } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import { MotionRecord } from "./motion-record.js";
import type { TwinFolder } from "./twin-folder.js";

export type { TrajectoryState } from "./motion-record.js";

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
  /** the gripper started or ended opening or closing (`gripper`) */
  gripper: [];
}

/** The `gripper` property: where the gripper is and what it holds. */
export interface GripperStatus {
  state: "open" | "closed" | "moving";
  holding: string | null;
  kind: "fingers" | "suction";
  /** s an opening or closing takes */
  time: number;
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
  /** the twin's own motion: busy, the streamed states, the relayed command (changed through its methods only: by the
   *  motion and relay sessions, and by `onState`/`onCollision` here) */
  readonly motion = new MotionRecord();
  /** `generate --gripper`: the gripper's state (null: the twin has none) */
  gripper: GripperStatus | null = null;
  /** `serve --follow`: the physical robot's state as `physicalState` reports it */
  private physicalView: (() => object) | null = null;

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

  /** true from the moment a move is accepted for validation until it ends */
  get busy(): boolean {
    return this.motion.busy;
  }

  /** `serve --follow`: the physical robot's state as `physicalState` reports it; null without a follower */
  get physical(): (() => object) | null {
    return this.physicalView;
  }

  /** The follower whose view `physicalState` shows (set once, when the twin is served). */
  follow(view: () => object): void {
    this.physicalView = view;
  }

  get joints(): string[] {
    return this.model?.controllable ?? [];
  }

  jointsRecord(q: readonly number[] = this.q): Record<string, number> {
    const out: Record<string, number> = {};
    this.joints.forEach((name, i) => (out[name] = q[i] ?? 0));
    return out;
  }

  /** A joint record -> the vector in `controllable` order. The record passed the TD's joints schema at the
   *  router: one finite number per controllable joint, no other key. */
  jointsVector(rec: Readonly<Record<string, number>>): number[] {
    return this.joints.map((name) => rec[name] as number);
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

  /** The gripper's new state (`gripper` event). */
  setGripper(patch: Partial<GripperStatus>): void {
    if (this.gripper === null) return;
    this.gripper = { ...this.gripper, ...patch };
    this.emit("gripper");
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
    this.motion.record({ time: params.time, q: [...params.positions], position, ...(params.step !== undefined ? { step: params.step } : {}) }, params.planned);
    this.applyPose(params.positions, params);
  }

  /** A motion stopped on contact: emits the `collision` event once per motion. */
  onCollision(contacts: Contact[], positions: number[]): void {
    const ev = this.collisionEvent(contacts, positions);
    if (!ev || !this.motion.firstCollision()) return;
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
