/**
 * The CLI's view of the simulation backend: starts the Python backend through `@robwot/sim-client` (or
 * connects to `--backend ws://...`) and exposes the few RPC methods the commands need.
 */
import { validateThingDescription } from "@robwot/core";
import { BackendSupervisor, deadlineFromEnv, launchConnector, urlConnector, type CollisionReport, type MoveitConfig, type RobotExpandXacroParams, type RobotAttachToolParams, type RobotLoadParams, type RobotLoadProgressNotification, type ToolAttached, type RobotMoveitConfigParams, type RobotReadSrdfParams, type RobotModel, type SimClient, type WorkspaceGenerateParams, type WorkspaceSummary, type SrdfInfo, type WorldList, type XacroExpanded } from "@robwot/sim-client";
import { CliError } from "./errors.js";

export type { RobotLoadProgressNotification, RobotModel, WorkspaceSummary, WorldList };
export interface Progress {
  stage: string;
  done: number;
  total: number;
}

export interface Backend {
  /** `pybullet_data.getDataPath()` of the backend (for example robots). */
  readonly pybulletData: string;
  /** Loads a robot; a first load reports each collision mesh it decomposes to `onMesh`. */
  loadRobot(params: RobotLoadParams, onMesh?: (mesh: RobotLoadProgressNotification) => void): Promise<RobotModel>;
  removeRobot(id: string): Promise<void>;
  loadScene(params: { path: string; packageRoots?: Record<string, string> }): Promise<void>;
  listWorld(): Promise<WorldList>;
  /** Self and environment contacts of the robot at `positions` (the world is not changed). */
  checkCollision(robot: string, positions: number[]): Promise<CollisionReport>;
  exportRobot(params: { robot: string; outDir: string }): Promise<void>;
  /** A xacro file expanded into a URDF file in a temporary folder of its own (the caller deletes it). */
  expandXacro(params: RobotExpandXacroParams): Promise<XacroExpanded>;
  /** What a MoveIt config package says about its robot (files, xacro args, velocity limits). */
  moveitConfig(params: RobotMoveitConfigParams): Promise<MoveitConfig>;
  /** An SRDF's groups, states and end effectors, every name checked against the URDF. */
  readSrdf(params: RobotReadSrdfParams): Promise<SrdfInfo>;
  /** The velocity and acceleration limits of a MoveIt-style joint_limits.yaml. */
  jointLimits(file: string): Promise<{ velocities: Record<string, number>; accelerations: Record<string, number> }>;
  /** A URDF with a tool (TCP link, optional mesh) mounted on its end effector, in a temporary folder. */
  attachTool(params: RobotAttachToolParams): Promise<ToolAttached>;
  /** Starts the backend's collision workers ahead of `generateWorkspace` (an optimisation: never fails). */
  warmUp(workers?: number): Promise<void>;
  generateWorkspace(
    params: WorkspaceGenerateParams,
    onProgress: (p: Progress) => void,
  ): Promise<WorkspaceSummary>;
  /** Leaves the world as found (when connected to a running backend) and stops an own backend. Idempotent. */
  close(): Promise<void>;
}

/** A backend silent this long during a generation has hung (ms; `ROBWOT_BACKEND_DEADLINE_MS` overrides). */
const WATCHDOG_DEAD_MS = deadlineFromEnv(30_000);

/** Generous per-request timeout: loading a mesh-heavy robot or a large scene can take a while. */
const REQUEST_TIMEOUT_MS = 120_000;

/**
 * The backend as the commands use it, under the shared supervisor (`@robwot/sim-client`) without restarts:
 * the backend answers ping from its event loop even while a generation runs, so one that leaves a ping
 * unanswered for WATCHDOG_DEAD_MS has hung (or was stopped). It is then killed (an own backend) or dropped
 * (a shared one), which fails every pending call at once; they fail with that reason instead of waiting.
 */
class SimBackend implements Backend {
  private closing: Promise<void> | null = null;
  private dead: CliError | null = null;

  constructor(
    private readonly supervisor: BackendSupervisor,
    readonly pybulletData: string,
    /** a backend someone else runs (`--backend`): left with an empty world, as found */
    private readonly shared: boolean,
  ) {
    supervisor.on("down", (reason) => {
      this.dead = new CliError(`the simulation backend stopped answering (${reason})`, "E_BACKEND", 1);
    });
  }

  private get client(): SimClient {
    return this.supervisor.sim;
  }

  /** A call that fails with the watchdog's reason when the backend was declared dead meanwhile. */
  private async guard<T>(call: Promise<T>): Promise<T> {
    try {
      return await call;
    } catch (err) {
      throw this.dead ?? err;
    }
  }

  loadRobot(params: RobotLoadParams, onMesh?: (mesh: RobotLoadProgressNotification) => void): Promise<RobotModel> {
    return this.guard(this.client.loadRobot(params, onMesh ? { onProgress: onMesh } : {}));
  }
  async removeRobot(id: string): Promise<void> {
    await this.guard(this.client.removeRobot({ robot: id }));
  }
  async loadScene(params: { path: string; packageRoots?: Record<string, string> }): Promise<void> {
    await this.guard(this.client.loadScene(params));
  }
  listWorld(): Promise<WorldList> {
    return this.guard(this.client.listWorld());
  }
  checkCollision(robot: string, positions: number[]): Promise<CollisionReport> {
    return this.guard(this.client.checkCollision({ robot, positions }));
  }
  expandXacro(params: RobotExpandXacroParams): Promise<XacroExpanded> {
    return this.guard(this.client.expandXacro(params));
  }
  moveitConfig(params: RobotMoveitConfigParams): Promise<MoveitConfig> {
    return this.guard(this.client.moveitConfig(params));
  }
  readSrdf(params: RobotReadSrdfParams): Promise<SrdfInfo> {
    return this.guard(this.client.readSrdf(params));
  }
  async jointLimits(file: string): Promise<{ velocities: Record<string, number>; accelerations: Record<string, number> }> {
    const { velocityLimits, accelerationLimits } = await this.guard(this.client.jointLimits({ file }));
    const defined = (r: Record<string, number | undefined>): Record<string, number> =>
      Object.fromEntries(Object.entries(r).filter((e): e is [string, number] => e[1] !== undefined));
    return { velocities: defined(velocityLimits), accelerations: defined(accelerationLimits) };
  }
  attachTool(params: RobotAttachToolParams): Promise<ToolAttached> {
    return this.guard(this.client.attachTool(params));
  }
  async exportRobot(params: { robot: string; outDir: string }): Promise<void> {
    await this.guard(this.client.exportRobot(params));
  }
  async warmUp(workers?: number): Promise<void> {
    // only a head start for the worker pool: if it fails, workspace.generate starts the pool itself and
    // reports any real failure (an older backend without workspace.warmUp also lands here)
    await this.client.warmUp(workers === undefined ? {} : { workers }).catch(() => undefined);
  }
  generateWorkspace(
    params: WorkspaceGenerateParams,
    onProgress: (p: Progress) => void,
  ): Promise<WorkspaceSummary> {
    return this.guard(this.client.generateWorkspace(params, { onProgress }));
  }
  close(): Promise<void> {
    this.closing ??= (async () => {
      // a shared backend: leave its world empty, as we found it
      if (this.shared) await this.client.resetWorld().catch(() => undefined);
      await this.supervisor.stop(); // an own backend is stopped, a shared one's connection closed
    })();
    return this.closing;
  }
}

/**
 * Loads the official TD validator and runs it once (~0.8 s of CPU, about half of it one-off) while the
 * backend's Python starts up and leaves a core idle; the generate pipeline's two validations then run
 * faster, the first one beside the collision labelling, the last one on the critical path. Never fails.
 */
async function warmTdValidator(): Promise<void> {
  await validateThingDescription({
    "@context": "https://www.w3.org/2022/wot/td/v1.1",
    title: "warm-up",
    securityDefinitions: { nosec_sc: { scheme: "nosec" } },
    security: "nosec_sc",
  }).catch(() => undefined);
}

/**
 * Starts an own backend, or connects to `url`. A running backend must have an empty world (generation
 * labels collisions against everything in it); it is reset again on close.
 */
export async function openBackend(url?: string): Promise<Backend> {
  const deadlines = { heartbeatMs: Math.min(2_000, WATCHDOG_DEAD_MS / 2), deadAfterMs: WATCHDOG_DEAD_MS, restoreMs: WATCHDOG_DEAD_MS };
  const connector = url === undefined ? launchConnector({ requestTimeoutMs: REQUEST_TIMEOUT_MS }) : urlConnector(url, { requestTimeoutMs: REQUEST_TIMEOUT_MS });
  const supervisor = new BackendSupervisor(connector, async () => undefined, { restart: false, deadlines });
  const starting = supervisor.start();
  starting.catch(() => undefined); // awaited below; not "unhandled" while the validator warms up
  await warmTdValidator();
  try {
    await starting;
  } catch (err) {
    if (url === undefined) throw err;
    throw new CliError(`cannot connect to the backend at ${url}: ${(err as Error).message}`, "E_BACKEND", 1);
  }
  try {
    const ping = await supervisor.sim.ping();
    if (url !== undefined) {
      const world = await supervisor.sim.listWorld();
      if (world.robots.length > 0 || world.obstacles.length > 0) {
        throw new CliError(
          `the backend at ${url} is in use (${world.robots.length} robot(s), ${world.obstacles.length} obstacle(s) loaded); ` +
            "generate needs an empty world: omit --backend to start a dedicated one",
          "E_BACKEND",
          1,
        );
      }
    }
    return new SimBackend(supervisor, ping.pybulletData, url !== undefined);
  } catch (err) {
    // the backend is being abandoned after an error that is reported instead
    await supervisor.stop().catch(() => undefined);
    throw err;
  }
}
