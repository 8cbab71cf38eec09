/**
 * Errors of the servient. Every error has an HTTP status, a stable string `code` and structured
 * `details`; the HTTP middleware turns it into a JSON body `{code, message, details}`.
 *
 * Status codes (Contract 4, documented in the README):
 * - 400 schema violation / malformed JSON / degenerate calibration input (`E_BAD_INPUT`, `E_BAD_JSON`, ...)
 * - 401 missing or wrong credentials (`E_UNAUTHORIZED`)
 * - 404 unknown obstacle / file (`E_NOT_FOUND`); 405 a method the route does not serve (`E_METHOD_NOT_ALLOWED`)
 * - 409 a move while the twin is moving (`E_BUSY`), obstacle name taken (`E_NAME_TAKEN`)
 * - 422 the target was rejected by simulation-in-the-loop validation (`E_REJECTED`)
 * - 503 the simulation backend is down or restarting (`E_BACKEND_DOWN`)
 */
import { RobwotError } from "@robwot/core";

export type Details = Record<string, unknown>;

/** A RobwotError (the one TypeScript error base: string `code`, `details`, `toJSON`) with its HTTP status. */
export class ServientError extends RobwotError {
  override name = "ServientError";
  readonly status: number;

  constructor(status: number, code: string, message: string, details: Details = {}) {
    super(code, message, details);
    this.status = status;
  }
}

export const badInput = (message: string, details: Details = {}): ServientError =>
  new ServientError(400, "E_BAD_INPUT", message, details);

export const backendDown = (message: string, details: Details = {}): ServientError =>
  new ServientError(503, "E_BACKEND_DOWN", message, details);

/** Shape of a JSON-RPC error as thrown by the sim-client (error.code, error.data.code, data fields). */
interface RpcLikeError {
  code?: unknown;
  message?: unknown;
  data?: unknown;
}

/** Maps the backend's JSON-RPC error codes (Contract 1) to HTTP statuses. */
const RPC_STATUS: Record<string, number> = {
  E_INVALID_PARAMS: 400,
  E_OUT_OF_LIMITS: 400,
  E_UNKNOWN_OBJECT: 404,
  E_UNKNOWN_ROBOT: 404,
  E_UNKNOWN_LINK: 400,
  E_FILE_NOT_FOUND: 400,
  E_FORBIDDEN: 400,
  E_PATH_ESCAPE: 400,
  E_SCENE: 400,
  E_UNREACHABLE: 422,
  E_REJECTED: 422,
  E_BUSY: 409,
  E_MESH: 422,
  E_NAME_TAKEN: 409,
};

/** Converts anything thrown by a backend call into a ServientError (connection failures -> 503). */
export function fromBackendError(err: unknown): ServientError {
  if (err instanceof ServientError) return err;
  const e = (err ?? {}) as RpcLikeError;
  const data = (typeof e.data === "object" && e.data !== null ? e.data : {}) as Record<string, unknown>;
  const strCode =
    typeof data.code === "string" ? data.code : typeof e.code === "string" && e.code.startsWith("E_") ? e.code : undefined;
  const message = typeof e.message === "string" ? e.message : String(err);
  if (strCode === "E_CONNECTION_CLOSED" || strCode === "E_BACKEND_START") {
    return backendDown(`simulation backend unavailable: ${message}`);
  }
  if (strCode === "E_TIMEOUT") return new ServientError(504, "E_BACKEND_TIMEOUT", message);
  if (strCode !== undefined && strCode !== "E_INTERNAL") {
    const status = RPC_STATUS[strCode] ?? 500;
    const { code: _c, ...rest } = data;
    return new ServientError(status, strCode, message, rest);
  }
  if (strCode === "E_INTERNAL") return new ServientError(500, "E_INTERNAL", message, data);
  // no JSON-RPC error object: the connection or the process failed
  return backendDown(`simulation backend unavailable: ${message}`);
}
