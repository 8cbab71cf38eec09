/**
 * Shared value types (structural; compatible with the sim-client's RPC types, see ARCHITECTURE.md
 * Contracts 1-3). Units: metres, radians, seconds. Frame: simulation world frame, Z up.
 * Quaternions as tuples are `[x, y, z, w]`; as objects `{x, y, z, w}`.
 */

import type { Calibration } from "./calibration.js";

export type Vec3 = [number, number, number];
/** Quaternion `[x, y, z, w]`. */
export type QuatXyzw = [number, number, number, number];

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

export type JointType = "revolute" | "continuous" | "prismatic" | "fixed";

export interface MimicSpec {
  joint: string;
  multiplier: number;
  offset: number;
}

export interface JointSpec {
  name: string;
  type: JointType;
  /** rad (revolute/continuous: continuous joints report -pi) or m (prismatic) */
  lower: number;
  upper: number;
  /** rad/s or m/s */
  velocity: number;
  /** N·m or N */
  effort: number;
  parent?: string;
  child?: string;
  mimic?: MimicSpec;
}

/** The subset of the backend's `RobotModel` the core needs. */
export interface RobotModelLike {
  id?: string;
  name: string;
  eeLink: string;
  joints: JointSpec[];
  /** Names of the joints forming joint vectors (no fixed, no mimic joints), in vector order. */
  controllable: string[];
  links?: string[];
  basePosition?: Vec3;
  baseOrientation?: QuatXyzw;
}

export interface Bounds {
  min: Vec3;
  max: Vec3;
}

/** `workspace.json` (Contract 2). */
export interface WorkspaceSummary {
  samples: number;
  collisionFree: number;
  bounds: Bounds;
  alpha: number | null;
  method: "alpha-shape" | "convex-hull";
  /** m^3 */
  volume: number;
  seed: number;
  /** seconds per stage */
  timings: { sample: number; collide: number; alpha: number; write: number };
  versions?: Record<string, string>;
}

/** `twin.json` (Contract 2). */
export interface TwinManifest {
  version: 1;
  /** `srdf`: the robot's SRDF copied into the folder (its disabled collision pairs are never checked) */
  robot: { urdf: string; eeLink: string; basePosition: Vec3; baseOrientation: QuatXyzw; name: string; srdf?: string };
  scene: string;
  generatedAt: string;
  tool: string;
}

export interface ContactSide {
  /** robot id or obstacle name */
  body: string;
  /** link name, or null for an obstacle / base */
  link: string | null;
}

export interface Contact {
  a: ContactSide;
  b: ContactSide;
  /** penetration depth, m, >= 0 */
  depth: number;
  position: Vec3;
}

export type MoveStatus = "reached" | "stopped" | "collision";

/** Output of the move actions (Contract 3). */
export interface MoveResult {
  status: MoveStatus;
  joints: Record<string, number>;
  position: Xyz;
  orientation: Quaternion;
  /** s */
  duration: number;
  /** m, Cartesian moves */
  positionError?: number;
}

export interface MotionStatus {
  state: "idle" | "moving" | "stopped" | "collision";
  lastError: { code: string; message: string } | null;
  lastResult: MoveResult | null;
}

/** Output of validateJointPosition / validateCartesianPosition (Contract 3). */
export interface ValidationReport {
  /** the simulation's verdict: IK reach within limits and a collision-free path in the current scene */
  valid: boolean;
  reasons: string[];
  /** static checks (workspace.stl, point cloud) that disagree with or add to the verdict; never a veto */
  notes?: string[];
  checks: {
    limits?: { ok: boolean; violations?: { joint: string; value: number; lower: number; upper: number }[] };
    insideWorkspace?: { ok: boolean };
    pointCloud?: { score: number; threshold: number; k: number; ok: boolean };
    ik?: { ok: boolean; positionError: number };
    path?: { ok: boolean; contacts: Contact[] };
  };
}

/** `collision` event data (Contract 3). */
export interface CollisionEvent {
  pair: { a: ContactSide; b: ContactSide };
  position: Xyz;
  depth: number;
  joints: Record<string, number>;
}

/** `calibration.json` (Contract 2): x_real = scale · rotation · x_virtual + translation. */
export type CalibrationFile = Omit<Calibration, "residuals"> & { createdAt: string };
