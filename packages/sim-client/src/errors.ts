/** Errors of the sim-client. Each class sets `name`; the non-RPC ones carry a stable string `code`. */

/** `error.data` of a JSON-RPC error: a stable string `code` (`E_UNKNOWN_ROBOT`, ...) plus fields. */
export interface RpcErrorData {
  code: string;
  [field: string]: unknown;
}

/** A JSON-RPC error answered by the backend: numeric `code` (-326xx / -320xx) and structured `data`. */
export class RpcError extends Error {
  override readonly name = "RpcError";
  readonly code: number;
  readonly data: RpcErrorData;
  readonly method: string;

  constructor(code: number, message: string, data: RpcErrorData, method: string) {
    super(message);
    this.code = code;
    this.data = data;
    this.method = method;
  }

  /** the stable string code, `data.code` */
  get dataCode(): string {
    return this.data.code;
  }
}

/** No answer within the request timeout (the request may still complete on the backend). */
export class RpcTimeoutError extends Error {
  override readonly name = "RpcTimeoutError";
  readonly code = "E_TIMEOUT";
  constructor(
    readonly method: string,
    readonly timeoutMs: number,
  ) {
    super(`no answer to ${method} within ${timeoutMs} ms`);
  }
}

/** The WebSocket closed (or could not open) while a request was pending. */
export class ConnectionClosedError extends Error {
  override readonly name = "ConnectionClosedError";
  readonly code = "E_CONNECTION_CLOSED";
  constructor(
    message: string,
    readonly url: string,
  ) {
    super(message);
  }
}

/** The backend process could not be started or did not report ready in time. */
export class BackendStartError extends Error {
  override readonly name = "BackendStartError";
  readonly code = "E_BACKEND_START";
  constructor(
    message: string,
    readonly stderrTail: string,
    readonly exitCode: number | null = null,
  ) {
    super(stderrTail ? `${message}\n--- backend stderr (tail) ---\n${stderrTail}` : message);
  }
}

/** True for a JSON-RPC error from the backend with the given `data.code`. */
export function isRpcError(err: unknown, dataCode?: string): err is RpcError {
  return err instanceof RpcError && (dataCode === undefined || err.data.code === dataCode);
}
