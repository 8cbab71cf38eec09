/**
 * Types of the backend's JSON-RPC methods (ARCHITECTURE.md Contract 1; authoritative text:
 * `sim-backend/PROTOCOL.md`). Units: metres, radians, seconds. Frame: simulation world frame, Z up.
 * Quaternions are `[x, y, z, w]`. Joint vectors follow the model's `controllable` order.
 */

export type Vec3 = [number, number, number];
/** Quaternion `[x, y, z, w]`. */
export type QuatXyzw = [number, number, number, number];

export type JointType = "revolute" | "continuous" | "prismatic" | "fixed";

export interface Mimic {
  joint: string;
  multiplier: number;
  offset: number;
}

export interface JointModel {
  name: string;
  type: JointType;
  parent: string;
  child: string;
  /** rad (revolute; continuous joints report -pi..pi) or m (prismatic) */
  lower: number;
  upper: number;
  /** rad/s or m/s */
  velocity: number;
  /** N·m or N */
  effort: number;
  mimic?: Mimic;
}

export interface RobotModel {
  id: string;
  name: string;
  /** absolute path of the URDF the robot was loaded from */
  urdf: string;
  eeLink: string;
  links: string[];
  joints: JointModel[];
  /** joints forming joint vectors (no fixed, no mimic joints), in vector order */
  controllable: string[];
  /** link pairs never checked for self-collision (adjacent or touching in every configuration) */
  filteredPairs: [string, string][];
  basePosition: Vec3;
  baseOrientation: QuatXyzw;
  /** the SRDF whose disabled pairs are in filteredPairs (absolute path), when loaded with one */
  srdf?: string;
}

export type ObstacleShape =
  | { type: "box"; size: Vec3 }
  | { type: "sphere"; radius: number }
  | { type: "cylinder"; radius: number; length: number }
  | { type: "mesh"; file: string; scale?: number | Vec3 };

export interface Obstacle {
  name: string;
  shape: ObstacleShape;
  position: Vec3;
  /** `[x, y, z, w]`; give either `orientation` or `rpy` (rad) */
  orientation?: QuatXyzw;
  rpy?: Vec3;
}

export interface WorldRobot {
  id: string;
  urdf: string;
  basePosition: Vec3;
  baseOrientation: QuatXyzw;
  eeLink: string;
}

export interface WorldList {
  robots: WorldRobot[];
  obstacles: Obstacle[];
}

export interface SceneLoaded {
  robots: string[];
  obstacles: string[];
}

export interface BodyLink {
  /** robot id or obstacle name */
  body: string;
  /** link name, or null for an obstacle / a robot base */
  link: string | null;
}

export interface Contact {
  a: BodyLink;
  b: BodyLink;
  /** penetration depth in m (>= 0) */
  depth: number;
  position: Vec3;
}

export interface Ping {
  version: string;
  pybullet: string;
  pybulletData: string;
}

export interface JointPositions {
  names: string[];
  positions: number[];
}

export interface PoseResult {
  position: Vec3;
  orientation: QuatXyzw;
  /** the link whose frame this is (the end-effector link) */
  link: string;
}

export interface IkResult {
  positions: number[];
  /** m */
  positionError: number;
  /** rad */
  orientationError: number;
  collisionFree: boolean;
}

export interface CollisionReport {
  collisionFree: boolean;
  contacts: Contact[];
}

export interface PathReport {
  collisionFree: boolean;
  /** s of simulated time */
  duration: number;
  steps: number;
  firstCollision?: { time: number; positions: number[]; contacts: Contact[] };
}

export type MoveStatus = "reached" | "stopped" | "collision";

export interface MoveResult {
  status: MoveStatus;
  /** the last reached (collision-free) configuration */
  positions: number[];
  /** s of simulated time */
  duration: number;
  /** s of wall-clock time */
  wallTime: number;
  /** contacts that stopped the motion (status "collision"), else [] */
  contacts: Contact[];
}

export interface ExportResult {
  urdf: string;
  meshes: string[];
}

export interface Bounds {
  min: Vec3;
  max: Vec3;
}

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
  [extra: string]: unknown;
}

// ---- notifications ----

export interface RobotStateNotification {
  robot: string;
  /** s of simulated time since the motion started */
  time: number;
  positions: number[];
  moving: boolean;
}

export interface RobotCollisionNotification {
  robot: string;
  contacts: Contact[];
  /** the last collision-free configuration, where the robot stopped */
  positions: number[];
  time: number;
}

export interface WorkspaceProgressNotification {
  stage: "sample" | "collide" | "alpha" | "write";
  done: number;
  total: number;
}

export interface NotificationMap {
  "robot.state": RobotStateNotification;
  "robot.collision": RobotCollisionNotification;
  "workspace.progress": WorkspaceProgressNotification;
}
