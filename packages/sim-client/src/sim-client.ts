/**
 * Typed client of the simulation backend: one method per JSON-RPC method of the contract
 * (`sim-backend/src/robwot_sim/schemas/protocol.openrpc.json`; types generated into `@robwot/core/backend-contract`,
 * reference in `sim-backend/PROTOCOL.md`). Joint vectors follow the robot model's `controllable` order.
 *
 * It runs over anything that can call a method — a plain `RpcConnection`, or a supervisor that adds
 * deadlines and restarts (the servient's) — so method names live here and nowhere else.
 */
import { RpcConnection, type CallOptions, type RpcConnectionOptions } from "./rpc-connection.js";
import type { MethodName, Methods, Notifications, RobotLoadProgressNotification, WorkspaceProgressNotification } from "@robwot/core/backend-contract";

/** What the client needs from a transport: call a method, listen to notifications. */
export interface RpcCaller {
  call<T = unknown>(method: string, params?: object, options?: CallOptions): Promise<T>;
  /** `"*"` for every notification; returns the unsubscribe function */
  onNotification(method: string, listener: (method: string, params: Record<string, unknown>) => void): () => void;
  close(): Promise<void>;
}

type Params<M extends MethodName> = Methods[M]["params"];
type Result<M extends MethodName> = Promise<Methods[M]["result"]>;

export interface GenerateOptions extends CallOptions {
  onProgress?: (progress: WorkspaceProgressNotification) => void;
}

/**
 * Methods that may last minutes — a motion, a generation, a robot's first load (its concave meshes are
 * decomposed; a scene's robots too) — and that the backend runs off its loop, so its heartbeat keeps
 * answering: no request timeout of their own, the caller's heartbeat bounds them.
 */
export const LONG_METHODS: ReadonlySet<MethodName> = new Set<MethodName>([
  "robot.move",
  "program.run",
  "workspace.generate",
  "robot.load",
  "world.loadScene",
]);

export class SimClient {
  constructor(readonly rpc: RpcCaller) {}

  /** Connects to a running backend (`ws://127.0.0.1:PORT`). */
  static async connect(url: string, options: RpcConnectionOptions = {}): Promise<SimClient> {
    return new SimClient(await RpcConnection.open(url, options));
  }

  /** The WebSocket connection, when the client runs directly over one. */
  get connection(): RpcConnection {
    if (!(this.rpc instanceof RpcConnection)) throw new Error("this SimClient does not run over its own connection");
    return this.rpc;
  }

  close(): Promise<void> {
    return this.rpc.close();
  }

  /** Any method of the contract, typed by name. */
  request<M extends MethodName>(method: M, params: Params<M>, options: CallOptions = {}): Result<M> {
    const timeout = LONG_METHODS.has(method) ? { timeoutMs: 0 } : {};
    return this.rpc.call(method, params, { ...timeout, ...options });
  }

  /** Typed notification listener; returns the unsubscribe function. */
  on<K extends keyof Notifications>(method: K, listener: (params: Notifications[K]) => void): () => void {
    return this.rpc.onNotification(method, (_m, p) => listener(p as unknown as Notifications[K]));
  }

  /** Every notification (method, params); returns the unsubscribe function. */
  onNotification(listener: (method: string, params: Record<string, unknown>) => void): () => void {
    return this.rpc.onNotification("*", listener);
  }

  // ---- world ----
  ping(options?: CallOptions): Result<"ping"> {
    return this.request("ping", {}, options);
  }
  resetWorld(): Result<"world.reset"> {
    return this.request("world.reset", {});
  }
  listWorld(): Result<"world.list"> {
    return this.request("world.list", {});
  }
  loadScene(params: Params<"world.loadScene">): Result<"world.loadScene"> {
    return this.request("world.loadScene", params);
  }

  // ---- robots ----
  /** Loads a robot; a first load's new collision meshes are reported to `onMesh` as each is decomposed. */
  async loadRobot(params: Params<"robot.load">, onMesh?: (mesh: RobotLoadProgressNotification) => void): Result<"robot.load"> {
    const off = onMesh ? this.on("robot.loadProgress", onMesh) : undefined;
    try {
      return await this.request("robot.load", params);
    } finally {
      off?.();
    }
  }
  removeRobot(robot: string): Result<"robot.remove"> {
    return this.request("robot.remove", { robot });
  }
  robotModel(robot: string): Result<"robot.model"> {
    return this.request("robot.model", { robot });
  }
  exportRobot(robot: string, outDir: string): Result<"robot.export"> {
    return this.request("robot.export", { robot, outDir });
  }
  expandXacro(params: Params<"robot.expandXacro">): Result<"robot.expandXacro"> {
    return this.request("robot.expandXacro", params);
  }
  moveitConfig(params: Params<"robot.moveitConfig">): Result<"robot.moveitConfig"> {
    return this.request("robot.moveitConfig", params);
  }
  jointLimits(params: Params<"robot.jointLimits">): Result<"robot.jointLimits"> {
    return this.request("robot.jointLimits", params);
  }
  attachTool(params: Params<"robot.attachTool">): Result<"robot.attachTool"> {
    return this.request("robot.attachTool", params);
  }
  readSrdf(params: Params<"robot.readSrdf">): Result<"robot.readSrdf"> {
    return this.request("robot.readSrdf", params);
  }
  getJointPositions(robot: string): Result<"robot.getJointPositions"> {
    return this.request("robot.getJointPositions", { robot });
  }
  setJointPositions(robot: string, positions: number[]): Result<"robot.setJointPositions"> {
    return this.request("robot.setJointPositions", { robot, positions });
  }
  fk(robot: string, positions?: number[]): Result<"robot.fk"> {
    return this.request("robot.fk", positions === undefined ? { robot } : { robot, positions });
  }
  ik(params: Params<"robot.ik">): Result<"robot.ik"> {
    return this.request("robot.ik", params);
  }
  checkCollision(robot: string, positions?: number[]): Result<"robot.checkCollision"> {
    return this.request("robot.checkCollision", positions === undefined ? { robot } : { robot, positions });
  }
  checkPath(params: Params<"robot.checkPath">): Result<"robot.checkPath"> {
    return this.request("robot.checkPath", params);
  }
  /** The verdict `move` would reach on a joint (`target`) or pose (`position`) target, without moving. */
  plan(params: Params<"robot.plan">): Result<"robot.plan"> {
    return this.request("robot.plan", params);
  }
  /** A program's steps planned one after the other (nothing moves): verdicts, durations, cycle time. */
  planProgram(params: Params<"program.plan">): Result<"program.plan"> {
    return this.request("program.plan", params);
  }
  /** Plans a program as `planProgram` (refused with E_REJECTED and the report when a step is refused) and
   * runs it; resolves when it ends (no timeout unless given). `robot.state` carries the running step. */
  runProgram(params: Params<"program.run">, options: CallOptions = {}): Result<"program.run"> {
    return this.request("program.run", params, options);
  }
  /** Plans (refused with E_REJECTED when no valid plan) and moves; resolves when the motion ends (no
   * timeout unless given). */
  move(params: Params<"robot.move">, options: CallOptions = {}): Result<"robot.move"> {
    return this.request("robot.move", params, options);
  }
  stop(robot: string): Result<"robot.stop"> {
    return this.request("robot.stop", { robot });
  }

  // ---- obstacles ----
  addObstacle(obstacle: Params<"obstacle.add">): Result<"obstacle.add"> {
    return this.request("obstacle.add", obstacle);
  }
  moveObstacle(pose: Params<"obstacle.move">): Result<"obstacle.move"> {
    return this.request("obstacle.move", pose);
  }
  removeObstacle(name: string): Result<"obstacle.remove"> {
    return this.request("obstacle.remove", { name });
  }

  // ---- workspace ----
  /** Starts the backend's collision worker pool in the background (returns at once), so a coming
   * `generateWorkspace` with the same `workers` count does not wait for it. */
  warmUp(workers?: number): Result<"workspace.warmUp"> {
    return this.request("workspace.warmUp", workers === undefined ? {} : { workers });
  }
  /** Blocking generation on the backend (no timeout unless given); progress via `onProgress`. */
  async generateWorkspace(params: Params<"workspace.generate">, options: GenerateOptions = {}): Result<"workspace.generate"> {
    const { onProgress, ...callOptions } = options;
    const off = onProgress ? this.on("workspace.progress", onProgress) : undefined;
    try {
      return await this.request("workspace.generate", params, callOptions);
    } finally {
      off?.();
    }
  }
}
