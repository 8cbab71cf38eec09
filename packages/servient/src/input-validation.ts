/**
 * Schema validation of action inputs against the TD, in the HTTP middleware, before node-wot sees the
 * request (node-wot would answer 500 with a text body). Objects are closed: a property the schema does
 * not name (e.g. an unknown joint) is a violation. Non-finite numbers cannot pass (JSON has no NaN;
 * 1e999 parses to Infinity and is refused explicitly).
 */
import AjvModule from "ajv";
import type { ErrorObject, ValidateFunction } from "ajv";
import { closeSchema } from "@robwot/core";
import { badInput, servientError } from "./errors.js";
import { jsonDepth } from "./request-guard.js";

/** Deepest array/object nesting accepted in an action body (the deepest TD input schema needs 3). */
export const MAX_JSON_DEPTH = 32;

const Ajv = AjvModule.default;
const ajv = new Ajv({ strict: false, allErrors: true, validateFormats: false, useDefaults: false });
const cache = new WeakMap<object, ValidateFunction>();

function compile(schema: object): ValidateFunction {
  let fn = cache.get(schema);
  if (!fn) {
    // generated TDs state their inputs closed already; closing again keeps older twin folders strict too
    fn = ajv.compile(closeSchema(schema) as object);
    cache.set(schema, fn);
  }
  return fn;
}

function findNonFinite(v: unknown, path: string): string | null {
  if (typeof v === "number") return Number.isFinite(v) ? null : path || "/";
  if (Array.isArray(v)) {
    for (let i = 0; i < v.length; i++) {
      const r = findNonFinite(v[i], `${path}/${i}`);
      if (r) return r;
    }
  } else if (v !== null && typeof v === "object") {
    for (const [k, x] of Object.entries(v)) {
      const r = findNonFinite(x, `${path}/${k}`);
      if (r) return r;
    }
  }
  return null;
}

function describe(e: ErrorObject): { path: string; message: string; params: Record<string, unknown> } {
  const path = e.instancePath || "/";
  let message = `${path} ${e.message ?? "is invalid"}`;
  if (e.keyword === "additionalProperties") message = `${path}: unknown property '${String(e.params.additionalProperty)}'`;
  if (e.keyword === "required") message = `${path}: missing required property '${String(e.params.missingProperty)}'`;
  return { path, message, params: e.params as Record<string, unknown> };
}

/** Compiles an input schema ahead of its first request (a served device's TD, checked at start); throws
 *  when the schema cannot be compiled. */
export function compileInput(schema: object): void {
  compile(schema);
}

/** Parses a request body (JSON text) for an action; throws 400 ServientErrors. */
export function parseBody(text: string, hasInput: boolean, action: string): unknown {
  if (text.trim().length === 0) {
    if (hasInput) throw servientError("E_MISSING_BODY", `action ${action} needs a JSON body`, { action });
    return undefined;
  }
  const depth = jsonDepth(text);
  if (depth > MAX_JSON_DEPTH) {
    throw servientError("E_TOO_DEEP", `request body nests ${depth} levels deep (at most ${MAX_JSON_DEPTH})`, { action, limit: MAX_JSON_DEPTH });
  }
  try {
    return JSON.parse(text);
  } catch (err) {
    throw servientError("E_BAD_JSON", `request body is not valid JSON: ${(err as Error).message}`, { action });
  }
}

/** Validates `value` against the affordance's data schema; throws a 400 naming every violation. */
export function validateInput(schema: object | undefined, value: unknown, action: string): void {
  if (!schema) return;
  const nonFinite = findNonFinite(value, "");
  if (nonFinite) throw badInput(`${nonFinite}: numbers must be finite`, { action, path: nonFinite });
  const fn = compile(schema);
  if (fn(value)) return;
  const errors = (fn.errors ?? []).map(describe);
  // oneOf failures repeat every branch's complaint: keep the most specific first
  errors.sort((a, b) => b.path.length - a.path.length);
  throw badInput(`invalid input for ${action}: ${errors.slice(0, 3).map((e) => e.message).join("; ")}`, { action, errors });
}
