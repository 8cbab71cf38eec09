/**
 * Shared value types. The backend's (Vec3, Contact, WorkspaceSummary, ...) come from the generated
 * `backend-contract.ts` (ARCHITECTURE.md Contract 1); the rest are the twin's (Contracts 2-3). Units: metres, radians, seconds. Frame: simulation world frame, Z up.
 * Quaternions as tuples are `[x, y, z, w]`; as objects `{x, y, z, w}`.
 */

import type * as Backend from "./backend-contract.js";
import type { Calibration } from "./calibration.js";
import type { ReachabilityCheck } from "./workspace/reachability.js";
import type { MoveStatus, QuatXyzw, Vec3 } from "./backend-contract.js";

export type { Bounds, Contact, JointType, MoveStatus, QuatXyzw, Vec3, WorkspaceSummary } from "./backend-contract.js";
export interface Xyz {
  x: number;
  y: number;
  z: number;
}
export interface Quaternion {
  x: number;
  y: number;
  z: number;
  w: number;
}

export interface Pose {
  position: Vec3;
  /** `[x, y, z, w]` */
  orientation: QuatXyzw;
}

/** A joint as the backend's `RobotModel` reports it (parent/child optional for hand-made models). */
export type JointSpec = Omit<Backend.JointModel, "parent" | "child"> & Partial<Pick<Backend.JointModel, "parent" | "child">>;

/** The subset of the backend's `RobotModel` the core needs. */
export interface RobotModelLike {
  id?: string;
  name: string;
  eeLink: string;
  joints: JointSpec[];
  /** Names of the joints forming joint vectors (no fixed joints, no followers), in vector order. */
  controllable: string[];
  /** the joints that follow others (`<mimic>`, `--couple`, `--keep-level`), in the controllable joints' coordinates */
  couplings?: Backend.Coupling[];
  links?: string[];
  basePosition?: Vec3;
  baseOrientation?: QuatXyzw;
  /** m its checked paths and motions keep to other bodies */
  clearance?: number;
}

/** A gripper as `generate --gripper` declares it: parallel fingers (finger joints, default every one found)
 *  or a suction cup at the TCP; `time` (s) an opening or closing takes, `capture` (m) how far from the TCP an
 *  object is caught. */
export interface GripperDecl {
  kind: "fingers" | "suction";
  joints?: string[];
  time: number;
  capture: number;
}

/** `twin.json` (Contract 2). */
export interface TwinManifest {
  version: 1;
  /** `srdf`: the robot's SRDF copied into the folder (its disabled collision pairs are never checked) */
  robot: {
    urdf: string;
    eeLink: string;
    basePosition: Vec3;
    baseOrientation: QuatXyzw;
    name: string;
    srdf?: string;
    clearance?: number;
    /** the start pose `serve` takes (rad or m by joint name; joints not named stay at 0): the SRDF's `home` */
    home?: { joints: Record<string, number>; from: string };
    /** `--limits FILE`: its name and the limits it gave (the velocities are robot.urdf's) */
    limits?: { file: string; velocities: Record<string, number>; accelerations?: Record<string, number>; jerks?: Record<string, number> };
    /** joint -> acceleration limit (rad/s^2 or m/s^2) from a joint_limits.yaml; other joints reach their velocity limit in the contract's `Acceleration.x-accelerationTime` */
    accelerations?: Record<string, number>;
    /** joint -> jerk limit (rad/s^3 or m/s^3) from a joint_limits.yaml (`max_jerk`): with any, every motion is jerk-limited */
    jerks?: Record<string, number>;
    /** `--couple` rules and those `--keep-level` derived (`FOLLOWER=EXPR`), passed to `robot.load` as `couplings` */
    couplings?: string[];
    /** `--tcp` / `--tool-mesh`: the tool robot.urdf carries, mounted on `flange`; `eeLink` is its TCP link */
    tool?: { flange: string; tcp: number[]; mesh?: string; shape?: { type: "box"; size: number[] } | { type: "cylinder"; radius: number; length: number } };
    /** `--gripper`: the robot's gripper, declared to the backend (`gripper.configure`) when serve loads it */
    gripper?: GripperDecl;
  };
  scene: string;
  generatedAt: string;
  tool: string;
}

/** Output of the move actions (Contract 3; the backend's `robot.move` answers `MoveResult`). */
export interface MoveOutput {
  status: MoveStatus;
  joints: Record<string, number>;
  position: Xyz;
  orientation: Quaternion;
  /** s */
  duration: number;
  /** m, Cartesian moves */
  positionError?: number;
  /** the path the twin planned: the straight joint-space one, a detour around obstacles, or a LIN */
  path?: "straight" | "detour" | "lin" | "circ";
}

/** What relaying a command to the physical robot's Thing gave (`--relay`): `result` is its answer. */
export interface RelayReport {
  ok: boolean;
  /** the physical robot's TD URL */
  target: string;
  action: string;
  result?: unknown;
  error?: string;
  /** a move sent as several commands (a detour's legs, then the target): the last one sent (from 0), of `legs` */
  leg?: number;
  legs?: number;
}

/** A move's output with, under `--relay`, the physical robot's part. */
export type RelayedMoveOutput = MoveOutput & { relay?: RelayReport };

export interface MotionStatus {
  state: "idle" | "moving" | "stopped" | "collision";
  /** absent when the last operation succeeded */
  lastError?: { code: string; message: string };
  /** absent before the first move */
  lastResult?: MoveOutput;
}

/** Output of validateJointPosition / validateCartesianPosition (Contract 3). */
export interface ValidationReport {
  /** the simulation's verdict: IK reach within limits and a collision-free path in the current scene */
  valid: boolean;
  reasons: string[];
  /** static checks (workspace.stl, point cloud) that disagree with or add to the verdict; never a veto */
  notes?: string[];
  /** the backend plan's checks (limits, ik, path) and the static ones on the twin's files */
  checks: Backend.PlanChecks & {
    insideWorkspace?: { ok: boolean };
    /** a collision-free sample within maxGap (m); score = share of colliding among the k nearest (reported) */
    pointCloud?: { score: number; k: number; nearestFree: number; maxGap: number; ok: boolean };
    /** the target's voxel of reachability.csv (index = share of the 64 approach directions reached) */
    reachability?: ReachabilityCheck;
  };
}

/** `collision` event data (Contract 3). */
export interface CollisionEvent {
  pair: { a: Backend.BodyLink; b: Backend.BodyLink };
  position: Xyz;
  depth: number;
  joints: Record<string, number>;
}

/** `calibration.json` (Contract 2): x_real = scale · rotation · x_virtual + translation. */
export type CalibrationFile = Omit<Calibration, "residuals"> & { createdAt: string };
