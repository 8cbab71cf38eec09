/**
 * Per-request context shared between the HTTP middleware and the affordance handlers through
 * AsyncLocalStorage: the middleware parses and validates the body once (`body`); a handler that
 * fails records its ServientError (`error`) so the middleware can answer with the right status and a
 * JSON body instead of node-wot's `500 <text>`.
 */
import { AsyncLocalStorage } from "node:async_hooks";
import { ServientError } from "./errors.js";

export interface RequestContext {
  body?: unknown;
  hasBody: boolean;
  error?: ServientError;
}

export const requestContext = new AsyncLocalStorage<RequestContext>();

export function toServientError(err: unknown): ServientError {
  if (err instanceof ServientError) return err;
  const e = err as { code?: unknown; message?: unknown; details?: unknown };
  if (typeof e?.code === "string" && e.code.startsWith("E_") && typeof e.message === "string") {
    // @robwot/core errors (RobwotError): bad input of a pure function, e.g. a degenerate calibration
    const details = typeof e.details === "object" && e.details !== null ? (e.details as Record<string, unknown>) : {};
    return new ServientError(400, e.code, e.message, details);
  }
  return new ServientError(500, "E_INTERNAL", err instanceof Error ? err.message : String(err));
}

/** Wraps an affordance handler: records failures in the request context, rethrows for node-wot. */
export function recordErrors<A extends unknown[], R>(fn: (...args: A) => Promise<R>): (...args: A) => Promise<R> {
  return async (...args: A): Promise<R> => {
    try {
      return await fn(...args);
    } catch (err) {
      const se = toServientError(err);
      const ctx = requestContext.getStore();
      if (ctx) ctx.error = se;
      throw se;
    }
  };
}
