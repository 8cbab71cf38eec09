/**
 * Backend supervision, the one for every user of a backend (the servient restarts, the CLI does not). One
 * simulation backend (a `robwot_sim` process, or an external URL) serves the whole world. When the
 * connection or the process dies the supervisor marks the backend down (calls fail with
 * `BackendDownError`, which the servient answers as 503 `E_BACKEND_DOWN`) and, with `restart`, relaunches /
 * reconnects it, lets the caller restore robots, scene and the last joint state (`restore` hook), and
 * marks it up again; without it the backend stays down and its calls fail with the reason.
 *
 * Deadlines: a backend that stops answering (hung, SIGSTOPped) is declared dead — the heartbeat `ping`
 * gets no answer within `deadAfterMs`, or any call times out — and is killed (a launched process) or
 * dropped (an external URL); every call in flight then fails and the restart above follows. Because the
 * world is rebuilt from the caller's record of confirmed operations, an operation that timed out is never
 * half-applied: the backend that might have applied it late is gone.
 *
 * The restore that rebuilds the world runs under the same heartbeat (its long methods carry no request
 * deadline), and at a restart it is bounded as a whole by `restoreMs`: a backend that hangs or never
 * finishes while the world is rebuilt is killed and replaced like any other. Every failed restart is
 * emitted (`restartFailed`), and retried after a growing pause.
 */
import { EventEmitter } from "node:events";
import { TRANSPORT } from "@robwot/core/backend-contract";
import { BackendDownError, RpcTimeoutError } from "./errors.js";
import { startHeartbeat } from "./heartbeat.js";
import { deadlineFromEnv } from "./launcher.js";
import type { CallOptions } from "./rpc-connection.js";
import { SimClient, type RpcCaller } from "./sim-client.js";

/** One live connection to a backend. */
export interface SimSession extends RpcCaller {
  /** Resolves when the connection (or the process behind it) is gone. */
  readonly closed: Promise<void>;
  /** pid of the backend process when we launched it */
  readonly pid?: number | undefined;
  /** Ends a backend that does not answer, at once (SIGKILL a launched process, drop a connection). */
  kill(): void;
  /** A launched process: resolves when it has exited, with how (code or signal) and its last words. */
  readonly exited?: Promise<string>;
}

/** The supervisor's deadlines in ms; the defaults are the contract's (`TRANSPORT`, the why of each there). */
export interface Deadlines {
  /** heartbeat period */
  heartbeatMs: number;
  /** a backend that leaves a ping unanswered this long is dead */
  deadAfterMs: number;
  /**
   * at a restart, the whole restore (scene, robots, joints) must finish within this. The first start is
   * bounded by the heartbeat alone, since decomposing meshes may take minutes.
   */
  restoreMs: number;
}

/** The contract's policy; `ROBWOT_BACKEND_DEADLINE_MS` overrides how long a ping may go unanswered. */
export const DEFAULT_DEADLINES: Deadlines = { heartbeatMs: TRANSPORT.heartbeatMs, deadAfterMs: deadlineFromEnv(TRANSPORT.deadAfterMs), restoreMs: TRANSPORT.restoreMs };


export type SimConnector = () => Promise<SimSession>;

export interface SupervisorEvents {
  notification: [method: string, params: Record<string, unknown>];
  down: [reason: string];
  up: [restarts: number];
  /** a restart attempt failed (it is retried); `attempt` counts from 1 since the backend went down */
  restartFailed: [err: Error, attempt: number];
}

export interface SupervisorOptions {
  /** pause before a restart attempt, times the attempt number (ms, default 250; at most 5 s) */
  retryDelayMs?: number;
  deadlines?: Deadlines;
  /** relaunch / reconnect a backend that died, restoring the world (default true); false: it stays down */
  restart?: boolean;
  /** what a call of `sim` throws for a backend error (default: the error as it is) */
  mapError?: (err: unknown) => Error;
}

export class BackendSupervisor extends EventEmitter<SupervisorEvents> {
  private session: SimSession | null = null;
  /** the session that closed last (its process's end stays readable: `exitReason`) */
  private lastSession: SimSession | null = null;
  private up = false;
  private stopping = false;
  private recovering: Promise<void> | null = null;
  private stopHeartbeat: (() => void) | null = null;
  private dead: string | null = null;
  /** the end of the last session that died: its process reaped once it has exited */
  private ended: Promise<void> = Promise.resolve();
  /** number of successful restarts since start */
  restarts = 0;

  private readonly retryDelayMs: number;
  private readonly deadlines: Deadlines;
  private readonly restart: boolean;
  private readonly mapError: (err: unknown) => Error;

  /**
   * The typed client every caller uses: `BackendDownError` while the backend is down or restarting, a call
   * that times out declares the backend dead; errors through `mapError`.
   */
  readonly sim = new SimClient({
    call: async <T>(method: string, params?: object, options?: CallOptions): Promise<T> => {
      try {
        return (await this.call(method, params, options)) as T;
      } catch (err) {
        throw this.mapError(err);
      }
    },
    onNotification: (method, listener) => {
      const forward = (m: string, p: Record<string, unknown>): void => {
        if (method === "*" || m === method) listener(m, p);
      };
      this.on("notification", forward);
      return () => void this.off("notification", forward);
    },
    close: () => this.stop(),
  });

  constructor(
    private readonly connect: SimConnector,
    /** builds the world on a fresh backend, through a client of that session alone */
    private readonly restore: (sim: SimClient) => Promise<void>,
    options: SupervisorOptions = {},
  ) {
    super();
    this.retryDelayMs = options.retryDelayMs ?? 250;
    this.deadlines = options.deadlines ?? DEFAULT_DEADLINES;
    this.restart = options.restart ?? true;
    this.mapError = options.mapError ?? ((err) => (err instanceof Error ? err : new Error(String(err))));
    // one `down` listener per relaying twin (its RelaySession) besides the servient's own
    this.setMaxListeners(0);
  }

  get isUp(): boolean {
    return this.up;
  }

  /** Why the backend was declared dead (a ping or a call unanswered in time); null while it answers. */
  get deadReason(): string | null {
    return this.dead;
  }

  /**
   * How the launched backend of the current or last session ended (exit code or signal, its last words
   * on stderr), once it has, waiting at most `withinMs`; undefined for a connection to a running backend
   * or a process still alive then.
   */
  async exitReason(withinMs: number): Promise<string | undefined> {
    const exited = (this.session ?? this.lastSession)?.exited;
    if (exited === undefined) return undefined;
    let timer: ReturnType<typeof setTimeout> | undefined;
    const late = new Promise<undefined>((resolve) => (timer = setTimeout(() => resolve(undefined), withinMs)));
    try {
      return await Promise.race([exited, late]);
    } finally {
      clearTimeout(timer);
    }
  }

  get pid(): number | undefined {
    return this.session?.pid;
  }

  async start(): Promise<void> {
    await this.open(false);
  }

  private async call(method: string, params?: object, options?: CallOptions): Promise<unknown> {
    const s = this.session;
    if (!s || !this.up) {
      throw new BackendDownError(this.restart ? "simulation backend is restarting; retry shortly" : `simulation backend is down (${this.dead ?? "connection closed"})`, { method });
    }
    try {
      return await s.call(method, params, options);
    } catch (err) {
      if (err instanceof RpcTimeoutError) {
        // the backend may still apply the call later: only a restart from the record keeps state consistent
        this.declareDead(s, `${method} got no answer in time`);
        throw new BackendDownError(`simulation backend did not answer ${method} in time; ${this.restart ? "restarting it" : "stopped it"}`, { method });
      }
      throw err;
    }
  }

  /** Kills a backend that stopped answering; the close handler then restarts it. */
  private declareDead(s: SimSession, reason: string): void {
    if (this.session !== s || this.dead !== null) return;
    this.dead = reason;
    this.up = false;
    s.kill();
  }

  private startHeartbeat(s: SimSession): void {
    this.clearHeartbeat();
    const ping = new SimClient(s);
    this.stopHeartbeat = startHeartbeat((o) => ping.ping({}, o), { periodMs: this.deadlines.heartbeatMs, deadAfterMs: this.deadlines.deadAfterMs }, (reason) =>
      this.declareDead(s, reason),
    );
  }

  private clearHeartbeat(): void {
    this.stopHeartbeat?.();
    this.stopHeartbeat = null;
  }

  /** Resolves when the backend is up (or rejects after `timeoutMs`). */
  async waitUp(timeoutMs = 30_000): Promise<void> {
    if (this.up) return;
    await new Promise<void>((resolve, reject) => {
      const t = setTimeout(() => {
        this.off("up", onUp);
        reject(new BackendDownError(`backend not up after ${timeoutMs} ms`));
      }, timeoutMs);
      const onUp = (): void => {
        clearTimeout(t);
        resolve();
      };
      this.once("up", onUp);
    });
  }

  async stop(): Promise<void> {
    this.stopping = true;
    this.up = false;
    this.clearHeartbeat();
    const s = this.session;
    this.session = null;
    // stopping: a session whose connection is already gone needs no closing
    if (s) await s.close().catch(() => undefined);
    await this.ended;
  }

  private async open(restart: boolean): Promise<void> {
    const s = await this.connect();
    s.onNotification("*", (method, params) => this.emit("notification", method, params));
    this.session = s;
    this.dead = null;
    const direct = new SimClient({
      call: async <T>(method: string, params?: object, options?: CallOptions): Promise<T> => {
        try {
          return await s.call<T>(method, params, options);
        } catch (err) {
          throw this.mapError(err);
        }
      },
      onNotification: (method, listener) => s.onNotification(method, listener),
      close: () => s.close(),
    });
    // the restore's long methods carry no request deadline: the heartbeat watches it too, and a restart's
    // restore as a whole must end within restoreMs
    this.startHeartbeat(s);
    const bound = restart
      ? setTimeout(() => this.declareDead(s, `restore not finished within ${this.deadlines.restoreMs} ms`), this.deadlines.restoreMs)
      : null;
    try {
      await this.restore(direct);
    } catch (err) {
      this.clearHeartbeat();
      const reason = this.dead;
      // the restore error is what matters (rethrown); closing the half-set-up session is best effort
      await s.close().catch(() => undefined);
      this.session = null;
      throw reason === null ? err : new Error(`backend declared dead while restoring the world (${reason}): ${(err as Error).message}`);
    } finally {
      if (bound) clearTimeout(bound);
    }
    if (this.stopping) {
      // stop() was called while this (re)start was under way: do not leave a backend behind
      this.clearHeartbeat();
      this.session = null;
      await s.close().catch(() => undefined); // best effort: we are stopping anyway
      return;
    }
    this.up = true;
    void s.closed.then(() => this.onClosed(s));
  }

  private onClosed(s: SimSession): void {
    if (this.session !== s || this.stopping) return;
    this.clearHeartbeat();
    this.up = false;
    this.lastSession = s;
    this.session = null;
    this.ended = s.close().catch(() => undefined); // a dead session is already gone: closing only waits for it
    this.emit("down", this.dead ?? "backend connection closed");
    if (!this.restart) return;
    this.recovering ??= this.recover().finally(() => {
      this.recovering = null;
    });
  }

  private async recover(): Promise<void> {
    let attempt = 0;
    while (!this.stopping) {
      attempt++;
      try {
        await this.open(true);
        if (this.stopping) return;
        this.restarts++;
        this.emit("up", this.restarts);
        return;
      } catch (err) {
        this.emit("restartFailed", err instanceof Error ? err : new Error(String(err)), attempt);
        await new Promise((r) => setTimeout(r, Math.min(this.retryDelayMs * attempt, 5_000)));
      }
    }
  }
}
