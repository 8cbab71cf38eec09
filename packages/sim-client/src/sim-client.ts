/**
 * Typed client of the simulation backend: one method per JSON-RPC method of the contract
 * (`sim-backend/src/robwot_sim/schemas/protocol.openrpc.json`; types generated into `@robwot/core/backend-contract`,
 * reference in `sim-backend/PROTOCOL.md`). Joint vectors follow the robot model's `controllable` order.
 *
 * The methods are generated from the contract (`methods.generated.ts`, `npm run gen:contract`): a method's
 * client name (`x-client`), whether it may last minutes (`x-long`) and its progress notification
 * (`x-progress`) live there and nowhere else. It runs over anything that can call a method — a plain
 * `RpcConnection`, or a supervisor that adds deadlines and restarts (the servient's).
 */
import { RpcConnection, type CallOptions, type RpcConnectionOptions } from "./rpc-connection.js";
import type { MethodName, Notifications } from "@robwot/core/backend-contract";
import { ContractMethods, LONG_METHODS, type Params, type Result } from "./methods.generated.js";

/** What the client needs from a transport: call a method, listen to notifications. */
export interface RpcCaller {
  call<T = unknown>(method: string, params?: object, options?: CallOptions): Promise<T>;
  /** `"*"` for every notification; returns the unsubscribe function */
  onNotification(method: string, listener: (method: string, params: Record<string, unknown>) => void): () => void;
  close(): Promise<void>;
}

export { LONG_METHODS };

export class SimClient extends ContractMethods {
  constructor(readonly rpc: RpcCaller) {
    super();
  }

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
  override request<M extends MethodName>(method: M, params: Params<M>, options: CallOptions = {}): Result<M> {
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

  /** Runs `call` with `listener` subscribed to `notification` meanwhile (a method's progress). */
  protected async listening<K extends keyof Notifications, T>(notification: K, listener: ((p: Notifications[K]) => void) | undefined, call: () => Promise<T>): Promise<T> {
    const off = listener ? this.on(notification, listener) : undefined;
    try {
      return await call();
    } finally {
      off?.();
    }
  }
}
