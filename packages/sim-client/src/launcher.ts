/**
 * Starts the Python backend (`python -m robwot_sim serve`) as a child process, waits for its
 * `{"event":"ready","port":N}` line and connects a SimClient. The child is stopped by `stop()`
 * (SIGTERM, then SIGKILL after a grace period) and killed when this Node process exits; should this
 * process die without cleaning up, the backend sees its stdin pipe close and exits by itself.
 *
 * The backend accepts only its owner: a fresh random token is handed to the child in its environment
 * (`ROBWOT_BACKEND_TOKEN`, never on the command line, which every local user can read) and presented
 * on every connection.
 *
 * Python interpreter, in order: `options.python`, env `ROBWOT_PYTHON`, `<repo>/sim-backend/.venv/bin/python`
 * (the repo root is `../../` from this package, i.e. `../../../` from `src/` or `dist/`).
 */
import { spawn, type ChildProcess } from "node:child_process";
import { randomBytes } from "node:crypto";
import { EventEmitter } from "node:events";
import { existsSync } from "node:fs";
import { fileURLToPath } from "node:url";
import { TRANSPORT } from "@robwot/core/backend-contract";
import { BackendStartError } from "./errors.js";
import type { RpcConnectionOptions } from "./rpc-connection.js";
import { SimClient } from "./sim-client.js";

export interface LaunchOptions extends RpcConnectionOptions {
  /** Python interpreter with robwot_sim installed */
  python?: string;
  /** interface to bind (default 127.0.0.1) */
  host?: string;
  /** TCP port (default 0 = any free port) */
  port?: number;
  /** how long to wait for the ready line in ms (default: the contract's `TRANSPORT.startTimeoutMs`) */
  startTimeoutMs?: number;
  /** grace period between SIGTERM and SIGKILL in `stop()` in ms (default: `TRANSPORT.stopTimeoutMs`) */
  stopTimeoutMs?: number;
  /** extra environment of the child */
  env?: NodeJS.ProcessEnv;
  /** working directory of the child (relative URDF paths resolve against it) */
  cwd?: string;
  /** start the labelling pool's worker processes (0: one per core) while the backend starts (`--warm-workers`):
   *  for a client that will generate a workspace */
  warmWorkers?: number;
}

export interface ExitInfo {
  code: number | null;
  signal: NodeJS.Signals | null;
}

export interface BackendEvents {
  /** the process ended (after `stop()` or unexpectedly) */
  exit: [info: ExitInfo];
}

const STDERR_TAIL_BYTES = 8_192;

/** How long (ms) a backend may leave a ping unanswered before its owner declares it dead:
 *  `ROBWOT_BACKEND_DEADLINE_MS` when set (>= 100; tests shorten it), else the contract's `TRANSPORT.deadAfterMs`. */
export function deadlineFromEnv(fallback: number = TRANSPORT.deadAfterMs): number {
  const v = Number(process.env.ROBWOT_BACKEND_DEADLINE_MS);
  return Number.isFinite(v) && v >= 100 ? v : fallback;
}

/** The repository's venv interpreter, located relative to this package. */
export function defaultPython(): string {
  return fileURLToPath(new URL("../../../sim-backend/.venv/bin/python", import.meta.url));
}

export function resolvePython(explicit?: string): string {
  return explicit ?? process.env.ROBWOT_PYTHON ?? defaultPython();
}

const live = new Set<ChildProcess>();
let exitHookInstalled = false;
function installExitHook(): void {
  if (exitHookInstalled) return;
  exitHookInstalled = true;
  process.on("exit", () => {
    for (const child of live) child.kill("SIGKILL");
  });
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
        live.delete(process);
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

/** Starts `python -m robwot_sim serve` and connects to it. */
export async function launchBackend(options: LaunchOptions = {}): Promise<LaunchedBackend> {
  const python = resolvePython(options.python);
  if (python.includes("/") && !existsSync(python)) {
    throw new BackendStartError(
      `Python interpreter not found: ${python} (run \`npm install\` at the repository root to create ` +
        "sim-backend/.venv, or set ROBWOT_PYTHON)",
      "",
    );
  }
  const host = options.host ?? "127.0.0.1";
  // --exit-on-stdin-eof: the backend ends when our end of its stdin pipe closes, even if we are SIGKILLed
  const args = ["-m", "robwot_sim", "serve", "--host", host, "--port", String(options.port ?? 0), "--exit-on-stdin-eof"];
  if (options.warmWorkers !== undefined) args.push("--warm-workers", String(options.warmWorkers));
  const token = randomBytes(32).toString("base64url");
  const child = spawn(python, args, {
    stdio: ["pipe", "pipe", "pipe"],
    env: { ...process.env, PYTHONUNBUFFERED: "1", ...options.env, ROBWOT_BACKEND_TOKEN: token },
    ...(options.cwd ? { cwd: options.cwd } : {}),
  });
  child.stdin?.on("error", () => undefined); // EPIPE once the child is gone: nothing is ever written
  installExitHook();
  live.add(child);
  child.once("exit", () => live.delete(child));

  let tail = "";
  child.stderr?.setEncoding("utf8");
  child.stderr?.on("data", (chunk: string) => {
    tail = (tail + chunk).slice(-STDERR_TAIL_BYTES);
  });
  const stderrTail = (): string => tail.trimEnd();

  let port: number;
  try {
    port = await waitReady(child, options.startTimeoutMs ?? TRANSPORT.startTimeoutMs, stderrTail);
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

function waitReady(child: ChildProcess, timeoutMs: number, stderrTail: () => string): Promise<number> {
  return new Promise((resolve, reject) => {
    let buffer = "";
    let settled = false;
    const finish = (err: Error | null, port?: number): void => {
      if (settled) return;
      settled = true;
      clearTimeout(timer);
      child.off("exit", onExit);
      child.off("error", onError);
      if (err) reject(err);
      else resolve(port as number);
    };
    const onData = (chunk: string): void => {
      buffer += chunk;
      let nl: number;
      while ((nl = buffer.indexOf("\n")) >= 0) {
        const line = buffer.slice(0, nl).trim();
        buffer = buffer.slice(nl + 1);
        const port = parseReady(line);
        if (port !== null) return finish(null, port);
      }
    };
    const onExit = (code: number | null, signal: NodeJS.Signals | null): void => {
      // give stderr a moment to flush its last chunk
      setTimeout(() => {
        const how = signal ? `signal ${signal}` : `code ${code}`;
        finish(new BackendStartError(`backend exited with ${how} before it was ready`, stderrTail(), code));
      }, 50);
    };
    const onError = (err: Error): void =>
      finish(new BackendStartError(`cannot start the backend: ${err.message}`, stderrTail()));
    const timer = setTimeout(
      () => finish(new BackendStartError(`backend not ready within ${timeoutMs} ms`, stderrTail())),
      timeoutMs,
    );
    child.stdout?.setEncoding("utf8");
    child.stdout?.on("data", onData);
    child.once("exit", onExit);
    child.once("error", onError);
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
