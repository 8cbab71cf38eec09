/**
 * The CLI's guard around the simulation backend: starts an own backend through `@robwot/sim-client` (or
 * connects to `--backend ws://...`), supervises it without restarts and hands out the generated client
 * (`guard.sim.<method>(params)`); it wraps no method. The deadlines are the contract's (`TRANSPORT`): the
 * backend answers ping from its event loop even while a generation runs, so one that leaves a ping
 * unanswered past the deadline has hung (or was stopped). It is then killed (an own backend) or dropped (a
 * shared one), which fails every pending call at once, with that reason instead of waiting.
 */
import { BackendDownError, BackendSupervisor, ConnectionClosedError, launchConnector, urlConnector, type SimClient, type SpawnedBackend } from "@robwot/sim-client";
import { CliError } from "./errors.js";

/** How long a dropped connection waits for its process's end to be known (the exit follows the socket's
 *  close within milliseconds; a process still alive after this is reported as the socket saw it). */
const EXIT_WAIT_MS = 2000;

export class BackendGuard {
  private closing: Promise<void> | null = null;

  private constructor(
    private readonly supervisor: BackendSupervisor,
    /** `pybullet_data.getDataPath()` of the backend (for example robots) */
    readonly pybulletData: string,
    /** a backend someone else runs (`--backend`): left with an empty world, as found */
    private readonly shared: boolean,
  ) {}

  /** The process id of an own backend (undefined for `--backend`). */
  get pid(): number | undefined {
    return this.shared ? undefined : this.supervisor.pid;
  }

  /** The typed client; once the backend was declared dead, every call fails with the reason. */
  get sim(): SimClient {
    return this.supervisor.sim;
  }

  /**
   * Starts an own backend (with its labelling pool starting at once for `warmWorkers`: 0 = one worker per
   * core; or takes `spawned`, its process started already), or connects to `url`. A running backend must have
   * an empty world (generation labels collisions against everything in it); it is reset again on close.
   */
  static async open(url?: string, warmWorkers?: number, spawned?: SpawnedBackend): Promise<BackendGuard> {
    const connector = url === undefined ? launchConnector({ warmWorkers, spawned }) : urlConnector(url);
    const supervisor: BackendSupervisor = new BackendSupervisor(connector, async () => undefined, {
      restart: false,
      mapError: (err) => {
        const reason = supervisor.deadReason;
        if (reason !== null) return new CliError(`the simulation backend stopped answering (${reason})`, "E_BACKEND", 1);
        return err instanceof Error ? err : new Error(String(err));
      },
    });
    try {
      await supervisor.start();
    } catch (err) {
      if (url === undefined) throw err;
      throw new CliError(`cannot connect to the backend at ${url}: ${(err as Error).message}`, "E_BACKEND", 1);
    }
    try {
      const ping = await supervisor.sim.ping();
      if (url !== undefined) await refuseBusy(supervisor.sim, url);
      return new BackendGuard(supervisor, ping.pybulletData, url !== undefined);
    } catch (err) {
      // the backend is being abandoned after an error that is reported instead
      await supervisor.stop().catch(() => undefined);
      throw err;
    }
  }

  /**
   * The error to report for `err`: a connection that closed under a call, when our own backend process has
   * ended, says how it ended (exit code or signal, and a native crash's report) instead of the socket's code.
   */
  async explain(err: unknown): Promise<unknown> {
    if (!(err instanceof ConnectionClosedError || err instanceof BackendDownError) || this.shared) return err;
    const how = await this.supervisor.exitReason(EXIT_WAIT_MS);
    return how === undefined ? err : new CliError(`the simulation backend ${how}`, "E_BACKEND", 1);
  }

  /** Leaves the world as found (when connected to a running backend) and stops an own backend. Idempotent. */
  close(): Promise<void> {
    this.closing ??= (async () => {
      // a shared backend: leave its world empty, as we found it
      if (this.shared) await this.sim.resetWorld().catch(() => undefined);
      await this.supervisor.stop(); // an own backend is stopped, a shared one's connection closed
    })();
    return this.closing;
  }
}

async function refuseBusy(sim: SimClient, url: string): Promise<void> {
  const world = await sim.listWorld();
  if (world.robots.length > 0 || world.obstacles.length > 0 || world.objects.length > 0) {
    throw new CliError(
      `the backend at ${url} is in use (${world.robots.length} robot(s), ${world.obstacles.length} obstacle(s), ${world.objects.length} object(s) loaded); ` +
        "generate needs an empty world: omit --backend to start a dedicated one",
      "E_BACKEND",
      1,
    );
  }
}
