/** Errors of the sim-client, all RobwotErrors (one base in TypeScript): a stable string `code`, `details`. */
import { RobwotError } from "@robwot/core/errors";

/** `error.data` of a JSON-RPC error: a stable string `code` (`E_UNKNOWN_ROBOT`, ...) plus fields. */
export interface RpcErrorData {
  code: string;
  [field: string]: unknown;
}

/** A JSON-RPC error answered by the backend: `code` = `data.code` (`E_UNKNOWN_ROBOT`, ...), the
 *  JSON-RPC number in `rpcCode` (-326xx / -320xx), the structured `data` also as `details`. */
export class RpcError extends RobwotError {
  override readonly name = "RpcError";
  readonly rpcCode: number;
  readonly data: RpcErrorData;
  readonly method: string;

  constructor(rpcCode: number, message: string, data: RpcErrorData, method: string) {
    super(data.code, message, data);
    this.rpcCode = rpcCode;
    this.data = data;
    this.method = method;
  }

  /** the stable string code, `data.code` */
  get dataCode(): string {
    return this.data.code;
  }
}

/** No answer within the request timeout (the request may still complete on the backend). */
export class RpcTimeoutError extends RobwotError {
  override readonly name = "RpcTimeoutError";
  constructor(
    readonly method: string,
    readonly timeoutMs: number,
  ) {
    super("E_TIMEOUT", `no answer to ${method} within ${timeoutMs} ms`, { method, timeoutMs });
  }
}

/** The WebSocket closed (or could not open) while a request was pending. */
export class ConnectionClosedError extends RobwotError {
  override readonly name = "ConnectionClosedError";
  constructor(
    message: string,
    readonly url: string,
  ) {
    super("E_CONNECTION_CLOSED", message, { url });
  }
}

/** The backend process could not be started or did not report ready in time. */
export class BackendStartError extends RobwotError {
  override readonly name = "BackendStartError";
  constructor(
    message: string,
    readonly stderrTail: string,
    readonly exitCode: number | null = null,
  ) {
    super("E_BACKEND_START", stderrTail ? `${message}\n--- backend stderr (tail) ---\n${stderrTail}` : message, { exitCode });
  }
}

/** A supervised backend is down, restarting, or was declared dead (`BackendSupervisor`); `details.method`
 *  names the call that could not be made. */
export class BackendDownError extends RobwotError {
  override readonly name = "BackendDownError";
  constructor(message: string, details: Record<string, unknown> = {}) {
    super("E_BACKEND_DOWN", message, details);
  }
}

/** True for a JSON-RPC error from the backend with the given `data.code`. */
export function isRpcError(err: unknown, dataCode?: string): err is RpcError {
  return err instanceof RpcError && (dataCode === undefined || err.data.code === dataCode);
}
