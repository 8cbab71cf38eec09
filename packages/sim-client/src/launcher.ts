/**
 * Starts the Python backend (`python -m robwot_sim serve`, `spawn.ts`) as a child process, or takes one
 * already started, waits for its `{"event":"ready","port":N}` line and connects a SimClient. The child is
 * stopped by `stop()` (SIGTERM, then SIGKILL after a grace period) and killed when this Node process exits;
 * should this process die without cleaning up, the backend sees its stdin pipe close and exits by itself.
 *
 * The backend accepts only its owner: a fresh random token is handed to the child in its environment
 * (`ROBWOT_BACKEND_TOKEN`, never on the command line, which every local user can read) and presented
 * on every connection.
 */
import type { ChildProcess } from "node:child_process";
import { EventEmitter } from "node:events";
import { TRANSPORT } from "@robwot/core/backend-contract";
import { BackendStartError } from "./errors.js";
import type { RpcConnectionOptions } from "./rpc-connection.js";
import { SimClient } from "./sim-client.js";
import { spawnBackend, type SpawnedBackend, type SpawnOptions } from "./spawn.js";

export { defaultPython, resolvePython } from "./spawn.js";

export interface LaunchOptions extends RpcConnectionOptions, SpawnOptions {
  /** how long to wait for the ready line in ms (default: the contract's `TRANSPORT.startTimeoutMs`) */
  startTimeoutMs?: number;
  /** grace period between SIGTERM and SIGKILL in `stop()` in ms (default: `TRANSPORT.stopTimeoutMs`) */
  stopTimeoutMs?: number;
  /** the backend process, started already by `spawnBackend` (the spawn options above are then unused) */
  spawned?: SpawnedBackend;
}

export interface ExitInfo {
  code: number | null;
  signal: NodeJS.Signals | null;
}

export interface BackendEvents {
  /** the process ended (after `stop()` or unexpectedly) */
  exit: [info: ExitInfo];
}

/** How long (ms) a backend may leave a ping unanswered before its owner declares it dead:
 *  `ROBWOT_BACKEND_DEADLINE_MS` when set (>= 100; tests shorten it), else the contract's `TRANSPORT.deadAfterMs`. */
export function deadlineFromEnv(fallback: number = TRANSPORT.deadAfterMs): number {
  const v = Number(process.env.ROBWOT_BACKEND_DEADLINE_MS);
  return Number.isFinite(v) && v >= 100 ? v : fallback;
}

/** A launched backend: its URL, connected client and child process. */
export class LaunchedBackend extends EventEmitter<BackendEvents> {
  /** resolves with the exit code/signal once the process has ended */
  readonly exited: Promise<ExitInfo>;
  private exitInfo: ExitInfo | null = null;
  private stopping: Promise<void> | null = null;

  constructor(
    readonly url: string,
    readonly port: number,
    /** the secret every connection to this backend presents (share it only with trusted code) */
    readonly token: string,
    readonly client: SimClient,
    readonly process: ChildProcess,
    private readonly stderrTail: () => string,
    private readonly stopTimeoutMs: number,
  ) {
    super();
    this.exited = new Promise((resolve) => {
      const done = (info: ExitInfo): void => {
        this.exitInfo = info;
        this.emit("exit", info);
        resolve(info);
      };
      if (process.exitCode !== null || process.signalCode !== null) {
        done({ code: process.exitCode, signal: process.signalCode });
      } else {
        process.once("exit", (code, signal) => done({ code, signal }));
      }
    });
  }

  get pid(): number | undefined {
    return this.process.pid;
  }

  get running(): boolean {
    return this.exitInfo === null;
  }

  /** the last lines the backend wrote to stderr */
  get stderr(): string {
    return this.stderrTail();
  }

  /**
   * Sends SIGTERM, closes the client and waits for exit (SIGKILL after the grace period). Idempotent. The
   * signal goes at the call itself, not after a turn of the event loop: a caller that stops the backend
   * and then computes (a generation checking its TD) has the backend exit meanwhile.
   */
  stop(): Promise<void> {
    this.stopping ??= (async () => {
      const running = this.running;
      if (running) this.process.kill("SIGTERM");
      await this.client.close().catch(() => undefined);
      if (!running) return;
      const timer = setTimeout(() => this.process.kill("SIGKILL"), this.stopTimeoutMs);
      await this.exited;
      clearTimeout(timer);
    })();
    return this.stopping;
  }
}

/** Starts `python -m robwot_sim serve` (or takes `options.spawned`) and connects to it. */
export async function launchBackend(options: LaunchOptions = {}): Promise<LaunchedBackend> {
  let spawned: SpawnedBackend;
  try {
    spawned = options.spawned ?? spawnBackend(options);
  } catch (err) {
    throw new BackendStartError(err instanceof Error ? err.message : String(err), "");
  }
  const { child, host, token } = spawned;
  const stderrTail = (): string => spawned.stderrTail();
  let port: number;
  try {
    port = await waitReady(spawned, options.startTimeoutMs ?? TRANSPORT.startTimeoutMs);
  } catch (err) {
    child.kill("SIGKILL");
    throw err;
  }
  const url = `ws://${host.includes(":") ? `[${host}]` : host}:${port}`;
  let client: SimClient;
  try {
    client = await SimClient.connect(url, { ...options, token });
  } catch (err) {
    child.kill("SIGKILL");
    throw new BackendStartError(`backend reported ready on ${url} but the connection failed: ${String(err)}`, stderrTail());
  }
  return new LaunchedBackend(url, port, token, client, child, stderrTail, options.stopTimeoutMs ?? TRANSPORT.stopTimeoutMs);
}

/** The port of the backend's ready line: in what it wrote already, or once it writes it. */
function waitReady(spawned: SpawnedBackend, timeoutMs: number): Promise<number> {
  const { child } = spawned;
  const stderrTail = (): string => spawned.stderrTail();
  return new Promise((resolve, reject) => {
    let buffer = spawned.stdout;
    let settled = false;
    const finish = (err: Error | null, port?: number): void => {
      if (settled) return;
      settled = true;
      clearTimeout(timer);
      child.stdout?.off("data", onData);
      child.off("exit", onExit);
      child.off("error", onError);
      if (err) reject(err);
      else resolve(port as number);
    };
    const lines = (): void => {
      let nl: number;
      while ((nl = buffer.indexOf("\n")) >= 0) {
        const port = parseReady(buffer.slice(0, nl).trim());
        buffer = buffer.slice(nl + 1);
        if (port !== null) return finish(null, port);
      }
    };
    const onData = (chunk: string): void => {
      buffer += chunk;
      lines();
    };
    const exitError = (code: number | null, signal: NodeJS.Signals | null): BackendStartError =>
      new BackendStartError(`backend exited with ${signal ? `signal ${signal}` : `code ${code}`} before it was ready`, stderrTail(), code);
    const onExit = (code: number | null, signal: NodeJS.Signals | null): void => {
      // give stderr a moment to flush its last chunk
      setTimeout(() => finish(exitError(code, signal)), 50);
    };
    const onError = (err: Error): void => finish(new BackendStartError(`cannot start the backend: ${err.message}`, stderrTail()));
    const timer = setTimeout(() => finish(new BackendStartError(`backend not ready within ${timeoutMs} ms`, stderrTail())), timeoutMs);
    child.stdout?.on("data", onData);
    child.once("exit", onExit);
    child.once("error", onError);
    lines();
    if (spawned.error !== null) onError(spawned.error);
    else if (child.exitCode !== null || child.signalCode !== null) onExit(child.exitCode, child.signalCode);
  });
}

function parseReady(line: string): number | null {
  if (!line.startsWith("{")) return null;
  try {
    const doc = JSON.parse(line) as { event?: unknown; port?: unknown };
    return doc.event === "ready" && typeof doc.port === "number" ? doc.port : null;
  } catch {
    return null;
  }
}

/** Connects to an already running backend. */
export function connect(url: string, options: RpcConnectionOptions = {}): Promise<SimClient> {
  return SimClient.connect(url, options);
}
