/**
 * Generic JSON-RPC 2.0 client over one WebSocket (`ws`): request ids, per-request timeouts,
 * server notifications. Knows nothing about the backend's methods (see sim-client.ts for those).
 */
import { EventEmitter } from "node:events";
import { TRANSPORT } from "@robwot/core/backend-contract";
import WebSocket from "ws";
import { ConnectionClosedError, RpcError, RpcTimeoutError, type RpcErrorData } from "./errors.js";

export interface RpcConnectionOptions {
  /** default timeout of each request in ms (default: the contract's `TRANSPORT.requestTimeoutMs`); 0 or
   *  Infinity disables it */
  requestTimeoutMs?: number;
  /** timeout of the WebSocket opening handshake in ms (default: `TRANSPORT.connectTimeoutMs`) */
  connectTimeoutMs?: number;
  /** the backend's secret, sent as `Authorization: Bearer <token>` on the upgrade (default: env
   *  ROBWOT_BACKEND_TOKEN); a backend refuses connections without it */
  token?: string | undefined;
}

export interface CallOptions {
  /** overrides the connection's default; 0 or Infinity waits forever */
  timeoutMs?: number;
}

export type NotificationListener = (method: string, params: Record<string, unknown>) => void;

interface Pending {
  method: string;
  resolve: (value: unknown) => void;
  reject: (err: Error) => void;
  timer: NodeJS.Timeout | undefined;
}

export interface RpcConnectionEvents {
  notification: [method: string, params: Record<string, unknown>];
  close: [code: number, reason: string];
}

export class RpcConnection extends EventEmitter<RpcConnectionEvents> {
  private nextId = 1;
  private readonly pending = new Map<number, Pending>();
  private readonly requestTimeoutMs: number;
  /** resolves once the socket is closed (never rejects) */
  readonly closed: Promise<void>;

  private constructor(
    private readonly ws: WebSocket,
    readonly url: string,
    options: RpcConnectionOptions,
  ) {
    super();
    this.requestTimeoutMs = options.requestTimeoutMs ?? TRANSPORT.requestTimeoutMs;
    ws.on("message", (data, isBinary) => this.onMessage(data, isBinary));
    this.closed = new Promise((resolve) => {
      ws.on("close", (code, reason) => {
        this.failAll(new ConnectionClosedError(`connection to ${url} closed (code ${code})`, url));
        this.emit("close", code, reason.toString());
        resolve();
      });
    });
    ws.on("error", () => {
      /* surfaced through "close" */
    });
  }

  /** Opens a connection to `url` (`ws://127.0.0.1:PORT`). */
  static open(url: string, options: RpcConnectionOptions = {}): Promise<RpcConnection> {
    return new Promise((resolve, reject) => {
      const token = options.token ?? process.env.ROBWOT_BACKEND_TOKEN;
      const ws = new WebSocket(url, {
        handshakeTimeout: options.connectTimeoutMs ?? TRANSPORT.connectTimeoutMs,
        ...(token ? { headers: { Authorization: `Bearer ${token}` } } : {}),
      });
      const onError = (err: Error): void => {
        ws.off("open", onOpen);
        const hint = /401|403/.test(err.message) ? " (the backend needs its token: set ROBWOT_BACKEND_TOKEN)" : "";
        reject(new ConnectionClosedError(`cannot connect to ${url}: ${err.message}${hint}`, url));
      };
      const onOpen = (): void => {
        ws.off("error", onError);
        resolve(new RpcConnection(ws, url, options));
      };
      ws.once("error", onError);
      ws.once("open", onOpen);
    });
  }

  get isOpen(): boolean {
    return this.ws.readyState === WebSocket.OPEN;
  }

  /** Calls `method`; resolves with `result`, rejects with RpcError / RpcTimeoutError / ConnectionClosedError. */
  call<T = unknown>(method: string, params?: object, options: CallOptions = {}): Promise<T> {
    if (!this.isOpen) {
      return Promise.reject(new ConnectionClosedError(`connection to ${this.url} is closed`, this.url));
    }
    const id = this.nextId++;
    const message = JSON.stringify({ jsonrpc: "2.0", id, method, ...(params === undefined ? {} : { params }) });
    const timeoutMs = options.timeoutMs ?? this.requestTimeoutMs;
    return new Promise<T>((resolve, reject) => {
      const timer =
        timeoutMs > 0 && Number.isFinite(timeoutMs)
          ? setTimeout(() => {
              this.pending.delete(id);
              reject(new RpcTimeoutError(method, timeoutMs));
            }, timeoutMs)
          : undefined;
      this.pending.set(id, { method, resolve: resolve as (v: unknown) => void, reject, timer });
      this.ws.send(message, (err) => {
        if (err) this.settle(id, new ConnectionClosedError(`send to ${this.url} failed: ${err.message}`, this.url));
      });
    });
  }

  /** Listens to one notification method (or every one with "*"); returns the unsubscribe function. */
  onNotification(method: string, listener: NotificationListener): () => void {
    const wrapped = (m: string, p: Record<string, unknown>): void => {
      if (method === "*" || m === method) listener(m, p);
    };
    this.on("notification", wrapped);
    return () => this.off("notification", wrapped);
  }

  /** Drops the socket at once (no closing handshake, for a peer that does not answer); pending requests
   *  reject with ConnectionClosedError. */
  terminate(): void {
    this.ws.terminate();
  }

  /** Closes the socket; pending requests reject with ConnectionClosedError. */
  async close(): Promise<void> {
    if (this.ws.readyState === WebSocket.CLOSED) return;
    this.ws.close(1000);
    const timer = setTimeout(() => this.ws.terminate(), 2_000);
    await this.closed;
    clearTimeout(timer);
  }

  private onMessage(data: WebSocket.RawData, isBinary: boolean): void {
    if (isBinary) return;
    let doc: unknown;
    try {
      doc = JSON.parse(data.toString());
    } catch {
      return; // the backend only sends JSON; ignore anything else
    }
    if (typeof doc !== "object" || doc === null) return;
    const msg = doc as Record<string, unknown>;
    if (typeof msg.method === "string" && msg.id === undefined) {
      const params = (typeof msg.params === "object" && msg.params !== null ? msg.params : {}) as Record<string, unknown>;
      this.emit("notification", msg.method, params);
      return;
    }
    if (typeof msg.id !== "number") return;
    const pending = this.pending.get(msg.id);
    if (!pending) return;
    if (msg.error && typeof msg.error === "object") {
      const e = msg.error as { code?: unknown; message?: unknown; data?: unknown };
      const data = (typeof e.data === "object" && e.data !== null ? e.data : {}) as Partial<RpcErrorData>;
      const rpcData: RpcErrorData = { ...data, code: typeof data.code === "string" ? data.code : "E_UNKNOWN" };
      this.settle(
        msg.id,
        new RpcError(typeof e.code === "number" ? e.code : -32603, String(e.message ?? "error"), rpcData, pending.method),
      );
    } else {
      this.settle(msg.id, undefined, msg.result);
    }
  }

  private settle(id: number, err: Error | undefined, result?: unknown): void {
    const pending = this.pending.get(id);
    if (!pending) return;
    this.pending.delete(id);
    if (pending.timer) clearTimeout(pending.timer);
    if (err) pending.reject(err);
    else pending.resolve(result);
  }

  private failAll(err: Error): void {
    for (const id of [...this.pending.keys()]) this.settle(id, err);
  }
}
