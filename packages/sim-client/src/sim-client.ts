/**
 * Typed client of the simulation backend: one method per JSON-RPC method of Contract 1
 * (`sim-backend/PROTOCOL.md`). Joint vectors follow the robot model's `controllable` order.
 */
import { RpcConnection, type CallOptions, type RpcConnectionOptions } from "./rpc-connection.js";
import type {
  CollisionReport,
  ExportResult,
  IkResult,
  JointPositions,
  MoveResult,
  NotificationMap,
  Obstacle,
  PathReport,
  Ping,
  PoseResult,
  QuatXyzw,
  RobotModel,
  SceneLoaded,
  Vec3,
  WorkspaceProgressNotification,
  WorkspaceSummary,
  WorldList,
} from "./types.js";

export interface LoadRobotParams {
  /** URDF file path (absolute, or relative to the backend's working directory) */
  urdf: string;
  id?: string;
  basePosition?: Vec3;
  baseOrientation?: QuatXyzw;
  eeLink?: string;
  packageRoots?: Record<string, string>;
  /** SRDF file: its `<disable_collisions>` pairs are never checked */
  srdf?: string;
}

export type LoadSceneParams =
  | { path: string; packageRoots?: Record<string, string> }
  | { scene: Record<string, unknown>; packageRoots?: Record<string, string> };

export interface IkParams {
  robot: string;
  position: Vec3;
  orientation?: QuatXyzw;
  seed?: number[];
  collisionFree?: boolean;
}

export interface CheckPathParams {
  robot: string;
  target: number[];
  from?: number[];
  /** fraction of the URDF velocity limits, (0, 1] */
  speed?: number;
  /** step in s (default 1/240) */
  dt?: number;
}

export interface MoveParams {
  robot: string;
  target: number[];
  speed?: number;
  /** real-time factor: 1 = wall clock, 0 = as fast as possible */
  realtime?: number;
  dt?: number;
}

export interface ObstaclePose {
  name: string;
  position: Vec3;
  orientation?: QuatXyzw;
  rpy?: Vec3;
}

export interface GenerateWorkspaceParams {
  robot: string;
  outDir: string;
  samples?: number;
  seed?: number;
  workers?: number;
  alpha?: "auto" | number;
  csvJoints?: boolean;
}

export interface GenerateOptions extends CallOptions {
  onProgress?: (progress: WorkspaceProgressNotification) => void;
}

export class SimClient {
  constructor(readonly connection: RpcConnection) {}

  /** Connects to a running backend (`ws://127.0.0.1:PORT`). */
  static async connect(url: string, options: RpcConnectionOptions = {}): Promise<SimClient> {
    return new SimClient(await RpcConnection.open(url, options));
  }

  get url(): string {
    return this.connection.url;
  }

  /** resolves when the connection is closed */
  get closed(): Promise<void> {
    return this.connection.closed;
  }

  /** Untyped call of any method. */
  call<T = unknown>(method: string, params?: object, options?: CallOptions): Promise<T> {
    return this.connection.call<T>(method, params, options);
  }

  /** Typed notification listener; returns the unsubscribe function. */
  on<K extends keyof NotificationMap>(method: K, listener: (params: NotificationMap[K]) => void): () => void {
    return this.connection.onNotification(method, (_m, p) => listener(p as unknown as NotificationMap[K]));
  }

  /** Every notification (method, params); returns the unsubscribe function. */
  onNotification(listener: (method: string, params: Record<string, unknown>) => void): () => void {
    return this.connection.onNotification("*", listener);
  }

  close(): Promise<void> {
    return this.connection.close();
  }

  // ---- world ----
  ping(options?: CallOptions): Promise<Ping> {
    return this.call("ping", undefined, options);
  }
  resetWorld(): Promise<Record<string, never>> {
    return this.call("world.reset");
  }
  listWorld(): Promise<WorldList> {
    return this.call("world.list");
  }
  loadScene(params: LoadSceneParams): Promise<SceneLoaded> {
    return this.call("world.loadScene", params);
  }

  // ---- robots ----
  loadRobot(params: LoadRobotParams): Promise<RobotModel> {
    return this.call("robot.load", params);
  }
  removeRobot(robot: string): Promise<Record<string, never>> {
    return this.call("robot.remove", { robot });
  }
  robotModel(robot: string): Promise<RobotModel> {
    return this.call("robot.model", { robot });
  }
  exportRobot(robot: string, outDir: string): Promise<ExportResult> {
    return this.call("robot.export", { robot, outDir });
  }
  getJointPositions(robot: string): Promise<JointPositions> {
    return this.call("robot.getJointPositions", { robot });
  }
  setJointPositions(robot: string, positions: number[]): Promise<JointPositions> {
    return this.call("robot.setJointPositions", { robot, positions });
  }
  fk(robot: string, positions?: number[]): Promise<PoseResult> {
    return this.call("robot.fk", positions === undefined ? { robot } : { robot, positions });
  }
  ik(params: IkParams): Promise<IkResult> {
    return this.call("robot.ik", params);
  }
  checkCollision(robot: string, positions?: number[]): Promise<CollisionReport> {
    return this.call("robot.checkCollision", positions === undefined ? { robot } : { robot, positions });
  }
  checkPath(params: CheckPathParams): Promise<PathReport> {
    return this.call("robot.checkPath", params);
  }
  /** Resolves when the motion ends (no timeout unless given). */
  move(params: MoveParams, options: CallOptions = {}): Promise<MoveResult> {
    return this.call("robot.move", params, { timeoutMs: 0, ...options });
  }
  stop(robot: string): Promise<{ stopped: boolean }> {
    return this.call("robot.stop", { robot });
  }

  // ---- obstacles ----
  addObstacle(obstacle: Obstacle): Promise<Obstacle> {
    return this.call("obstacle.add", obstacle);
  }
  moveObstacle(pose: ObstaclePose): Promise<Obstacle> {
    return this.call("obstacle.move", pose);
  }
  removeObstacle(name: string): Promise<Record<string, never>> {
    return this.call("obstacle.remove", { name });
  }

  // ---- workspace ----
  /** Starts the backend's collision worker pool in the background (returns at once), so a coming
   * `generateWorkspace` with the same `workers` count does not wait for it. */
  warmUp(workers?: number): Promise<{ workers: number }> {
    return this.call("workspace.warmUp", workers === undefined ? {} : { workers });
  }
  /** Blocking generation on the backend (no timeout unless given); progress via `onProgress`. */
  async generateWorkspace(params: GenerateWorkspaceParams, options: GenerateOptions = {}): Promise<WorkspaceSummary> {
    const { onProgress, ...callOptions } = options;
    const off = onProgress ? this.on("workspace.progress", onProgress) : undefined;
    try {
      return await this.call<WorkspaceSummary>("workspace.generate", params, { timeoutMs: 0, ...callOptions });
    } finally {
      off?.();
    }
  }
}
