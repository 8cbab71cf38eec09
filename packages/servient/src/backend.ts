/**
 * Backend supervision. One simulation backend (a `robwot_sim` process, or an external URL) serves the
 * whole world. When the connection or the process dies the supervisor marks the backend down (calls
 * answer 503 `E_BACKEND_DOWN`), reconnects / relaunches it, lets the world restore robots, scene and
 * the last joint state (`restore` hook), and marks it up again.
 */
import { EventEmitter } from "node:events";
import { backendDown, fromBackendError } from "./errors.js";

/** One live connection to a backend. */
export interface SimSession {
  call(method: string, params?: Record<string, unknown>): Promise<unknown>;
  /** Registers a listener for server notifications (`robot.state`, `robot.collision`, ...). */
  onNotification(cb: (method: string, params: Record<string, unknown>) => void): void;
  /** Resolves when the connection (or the process behind it) is gone. */
  readonly closed: Promise<void>;
  /** pid of the backend process when we launched it */
  readonly pid?: number | undefined;
  close(): Promise<void>;
}

export type SimConnector = () => Promise<SimSession>;
export type SimCall = (method: string, params?: Record<string, unknown>) => Promise<unknown>;

export interface SupervisorEvents {
  notification: [method: string, params: Record<string, unknown>];
  down: [reason: string];
  up: [restarts: number];
  error: [err: Error];
}

export class BackendSupervisor extends EventEmitter<SupervisorEvents> {
  private session: SimSession | null = null;
  private up = false;
  private stopping = false;
  private recovering: Promise<void> | null = null;
  /** number of successful restarts since start */
  restarts = 0;

  constructor(
    private readonly connect: SimConnector,
    private readonly restore: (call: SimCall) => Promise<void>,
    private readonly retryDelayMs = 250,
  ) {
    super();
  }

  get isUp(): boolean {
    return this.up;
  }

  get pid(): number | undefined {
    return this.session?.pid;
  }

  async start(): Promise<void> {
    await this.open();
  }

  /** Calls the backend; 503 when it is down, backend errors mapped to ServientError. */
  async call<T = unknown>(method: string, params?: Record<string, unknown>): Promise<T> {
    const s = this.session;
    if (!s || !this.up) throw backendDown("simulation backend is restarting; retry shortly", { method });
    try {
      return (await s.call(method, params)) as T;
    } catch (err) {
      throw fromBackendError(err);
    }
  }

  /** Resolves when the backend is up (or rejects after `timeoutMs`). */
  async waitUp(timeoutMs = 30_000): Promise<void> {
    if (this.up) return;
    await new Promise<void>((resolve, reject) => {
      const t = setTimeout(() => {
        this.off("up", onUp);
        reject(backendDown(`backend not up after ${timeoutMs} ms`));
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
    const s = this.session;
    this.session = null;
    if (s) await s.close().catch(() => undefined);
  }

  private async open(): Promise<void> {
    const s = await this.connect();
    s.onNotification((method, params) => this.emit("notification", method, params));
    this.session = s;
    const call: SimCall = async (method, params) => {
      try {
        return await s.call(method, params);
      } catch (err) {
        throw fromBackendError(err);
      }
    };
    try {
      await this.restore(call);
    } catch (err) {
      await s.close().catch(() => undefined);
      this.session = null;
      throw err;
    }
    if (this.stopping) {
      // stop() was called while this (re)start was under way: do not leave a backend behind
      this.session = null;
      await s.close().catch(() => undefined);
      return;
    }
    this.up = true;
    void s.closed.then(() => this.onClosed(s));
  }

  private onClosed(s: SimSession): void {
    if (this.session !== s || this.stopping) return;
    this.up = false;
    this.session = null;
    this.emit("down", "backend connection closed");
    this.recovering ??= this.recover().finally(() => {
      this.recovering = null;
    });
  }

  private async recover(): Promise<void> {
    let attempt = 0;
    while (!this.stopping) {
      attempt++;
      try {
        await this.open();
        if (this.stopping) return;
        this.restarts++;
        this.emit("up", this.restarts);
        return;
      } catch (err) {
        if (this.listenerCount("error") > 0) this.emit("error", err as Error);
        await new Promise((r) => setTimeout(r, Math.min(this.retryDelayMs * attempt, 5_000)));
      }
    }
  }
}
