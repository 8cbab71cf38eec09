/**
 * The backend's process started, and nothing else: `python -m robwot_sim serve` with a fresh token in its
 * environment, its output collected from the first byte, its failure to start and its exit recorded as they
 * happen. This module loads only Node's own modules and the contract's constants (`@robwot/sim-client/spawn`),
 * so a command can start the backend's Python first and load everything else while it starts
 * (`robwot generate`); `launchBackend` then waits for its ready line and connects.
 *
 * Python interpreter, in order: `options.python`, env `ROBWOT_PYTHON`, `<repo>/sim-backend/.venv/bin/python`
 * (the repo root is `../../` from this package, i.e. `../../../` from `src/` or `dist/`).
 */
import { spawn, type ChildProcess } from "node:child_process";
import { randomBytes } from "node:crypto";
import { existsSync } from "node:fs";
import { fileURLToPath } from "node:url";

export interface SpawnOptions {
  /** Python interpreter with robwot_sim installed */
  python?: string;
  /** interface to bind (default 127.0.0.1) */
  host?: string;
  /** TCP port (default 0 = any free port) */
  port?: number;
  /** extra environment of the child */
  env?: NodeJS.ProcessEnv;
  /** working directory of the child (relative URDF paths resolve against it) */
  cwd?: string;
  /** start the labelling pool's worker processes (0: one per core) while the backend starts (`--warm-workers`):
   *  for a client that will generate a workspace */
  warmWorkers?: number;
}

const OUTPUT_TAIL_BYTES = 8_192;

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

/** A started backend process: what it wrote so far, how it ended (once it did). */
export class SpawnedBackend {
  /** stdout so far (the ready line is looked for in it) */
  stdout = "";
  /** the process could not be started (e.g. no such interpreter): set once known */
  error: Error | null = null;
  private tail = "";

  constructor(
    readonly child: ChildProcess,
    /** the secret every connection to this backend presents (share it only with trusted code) */
    readonly token: string,
    readonly host: string,
    readonly python: string,
  ) {
    child.stdin?.on("error", () => undefined); // EPIPE once the child is gone: nothing is ever written
    installExitHook();
    live.add(child);
    child.once("exit", () => live.delete(child));
    child.once("error", (err) => {
      this.error = err;
      live.delete(child);
    });
    child.stdout?.setEncoding("utf8");
    child.stdout?.on("data", (chunk: string) => {
      this.stdout = (this.stdout + chunk).slice(-OUTPUT_TAIL_BYTES);
    });
    child.stderr?.setEncoding("utf8");
    child.stderr?.on("data", (chunk: string) => {
      this.tail = (this.tail + chunk).slice(-OUTPUT_TAIL_BYTES);
    });
  }

  /** the last lines the backend wrote to stderr */
  stderrTail(): string {
    return this.tail.trimEnd();
  }

  /** Kills the process (SIGKILL): for a backend nobody connected to. */
  kill(): void {
    this.child.kill("SIGKILL");
  }
}

/**
 * Starts `python -m robwot_sim serve`; returns at once. Throws (a plain `Error` naming the interpreter) only
 * when the interpreter's path does not exist; any other failure to start is `SpawnedBackend.error`.
 */
export function spawnBackend(options: SpawnOptions = {}): SpawnedBackend {
  const python = resolvePython(options.python);
  if (python.includes("/") && !existsSync(python)) {
    throw new Error(
      `Python interpreter not found: ${python} (run \`npm install\` at the repository root to create ` + "sim-backend/.venv, or set ROBWOT_PYTHON)",
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
  return new SpawnedBackend(child, token, host, python);
}
