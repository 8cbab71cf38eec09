/**
 * Errors of the servient. Every error has an HTTP status, a stable string `code` and structured
 * `details`; every HTTP error answer (`sendProblem`) is its RFC 7807 problem details
 * (`application/problem+json`: type, title, status, detail, and code, message, details; core `td/problem.ts`).
 *
 * A code has one HTTP status wherever it is raised: the contract's (`ERRORS`, `x-http-status`) for the codes
 * the backend shares, `SERVIENT_STATUS` for the servient's own; `servientError(code, ...)` looks it up, so no
 * status is typed beside a code (the table of both: packages/servient/README.md).
 */
import type { ServerResponse } from "node:http";
import { PROBLEM_JSON, problemDetails, RobwotError, type ProblemDetails } from "@robwot/core";
import { ERRORS, type ErrorCode } from "@robwot/core/backend-contract";
import { BackendDownError, RpcError, RpcTimeoutError } from "@robwot/sim-client";

export type Details = Record<string, unknown>;

/** A RobwotError (the one TypeScript error base: string `code`, `details`, `toJSON`) with its HTTP status. */
export class ServientError extends RobwotError {
  override name = "ServientError";
  readonly status: number;
  /** an answer in another shape than problem details: the error response a served device's TD declares
   *  (`as-device.ts`), its content type and body */
  shaped?: { contentType: string; body: unknown };

  constructor(status: number, code: string, message: string, details: Details = {}) {
    super(code, message, details);
    this.status = status;
  }

  /** RFC 7807 problem details of this error (the HTTP body, and a failed ActionStatus's `error`). */
  problem(): ProblemDetails {
    return problemDetails(this.status, this.code, this.message, this.details);
  }
}

/** The problem details body of `err` with its status; `headers` (e.g. `Allow`, `WWW-Authenticate`) beside. */
export function sendProblem(res: ServerResponse, err: ServientError, headers: Record<string, string> = {}): void {
  const text = JSON.stringify(err.shaped ? err.shaped.body : err.problem());
  res.writeHead(err.status, { ...headers, "Content-Type": err.shaped?.contentType ?? PROBLEM_JSON, "Content-Length": Buffer.byteLength(text) });
  res.end(text);
}

/** HTTP statuses of the servient's own codes, those the contract does not define. */
export const SERVIENT_STATUS = {
  E_BAD_INPUT: 400,
  E_BAD_JSON: 400,
  E_MISSING_BODY: 400,
  E_BAD_PATH: 400,
  E_CALIBRATION: 400,
  E_TWIN_FOLDER: 400,
  E_UNAUTHORIZED: 401,
  E_FORBIDDEN_ORIGIN: 403,
  E_NOT_FOUND: 404,
  E_METHOD_NOT_ALLOWED: 405,
  E_NOT_CANCELLABLE: 409,
  E_NOT_REACHED: 409,
  E_UNSUPPORTED_MEDIA_TYPE: 415,
  E_MISDIRECTED: 421,
  E_NOT_IMPLEMENTED: 501,
  E_BACKEND_DOWN: 503,
  E_STARTING: 503,
  E_BACKEND_TIMEOUT: 504,
  E_LOOP: 508,
} as const;

export type ServientCode = ErrorCode | keyof typeof SERVIENT_STATUS;

const isContractCode = (code: string): code is ErrorCode => Object.hasOwn(ERRORS, code);

/** The HTTP status of `code`: the contract's, else the servient's own. */
export const statusOf = (code: ServientCode): number => (isContractCode(code) ? ERRORS[code].httpStatus : SERVIENT_STATUS[code]);

/** An error of `code` with the one status that code has. */
export const servientError = (code: ServientCode, message: string, details: Details = {}): ServientError => new ServientError(statusOf(code), code, message, details);

export const badInput = (message: string, details: Details = {}): ServientError => servientError("E_BAD_INPUT", message, details);

export const backendDown = (message: string, details: Details = {}): ServientError => servientError("E_BACKEND_DOWN", message, details);

/**
 * Converts anything thrown by a backend call into a ServientError. A backend error's HTTP status is the
 * contract's (`x-http-status`, generated into `ERRORS`), so no code can be missing from a hand-kept table;
 * no answer in time is 504, a connection or process failure 503.
 */
export function fromBackendError(err: unknown): ServientError {
  if (err instanceof ServientError) return err;
  if (err instanceof RpcError) {
    const { code: _c, ...rest } = err.data;
    const status = isContractCode(err.code) ? ERRORS[err.code].httpStatus : 500;
    return new ServientError(status, err.code, err.message, err.code === "E_INTERNAL" ? err.data : rest);
  }
  if (err instanceof RpcTimeoutError) return servientError("E_BACKEND_TIMEOUT", err.message);
  if (err instanceof BackendDownError) return backendDown(err.message, err.details);
  // no JSON-RPC error object: the connection or the process failed
  const message = err instanceof Error ? err.message : String(err);
  return backendDown(`simulation backend unavailable: ${message}`);
}

/** Anything a handler threw, as a ServientError: @robwot/core's errors (bad input of a pure function, e.g. a
 *  degenerate calibration) are 400, anything else 500. */
export function toServientError(err: unknown): ServientError {
  if (err instanceof ServientError) return err;
  const e = err as { code?: unknown; message?: unknown; details?: unknown };
  if (typeof e?.code === "string" && e.code.startsWith("E_") && typeof e.message === "string") {
    const details = typeof e.details === "object" && e.details !== null ? (e.details as Details) : {};
    return new ServientError(400, e.code, e.message, details);
  }
  return servientError("E_INTERNAL", err instanceof Error ? err.message : String(err));
}
