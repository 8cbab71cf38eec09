/**
 * RFC 7807 problem details, the one error body of every HTTP answer of the twin (W3C WoT Profile,
 * "Errors": an error response's body MUST be a problem details object), also inside a failed
 * ActionStatus's `error`. The standard members are `type` (a URI per error code), `title` (the same for
 * every occurrence of that code), `status` (the HTTP status) and `detail` (this occurrence); RobWoT's
 * `code`, `message` (= `detail`) and `details` stay beside them as extension members, so clients written
 * against the earlier `{code, message, details}` body keep working.
 */
import type { DataSchema } from "./types.js";

export const PROBLEM_JSON = "application/problem+json";
/** A problem's `type`: this base + its code (`https://robwot.dev/errors#E_BUSY`); README "Errors". */
export const PROBLEM_TYPE_BASE = "https://robwot.dev/errors#";

export interface ProblemDetails {
  type: string;
  title: string;
  status: number;
  detail: string;
  code: string;
  message: string;
  details: Record<string, unknown>;
}

/** `E_BACKEND_DOWN` -> "Backend down": the title names the problem type, not the occurrence. */
export function problemTitle(code: string): string {
  const words = code.replace(/^E_/, "").toLowerCase().replace(/_/g, " ");
  return words.charAt(0).toUpperCase() + words.slice(1);
}

export function problemDetails(
  status: number,
  code: string,
  message: string,
  details: Record<string, unknown> = {},
): ProblemDetails {
  const type = PROBLEM_TYPE_BASE + code;
  return { type, title: problemTitle(code), status, detail: message, code, message, details };
}

/** The TD's `schemaDefinitions.error`: what every error answer's body holds. */
export const PROBLEM_SCHEMA: DataSchema = {
  type: "object",
  description:
    "An error answer, RFC 7807 problem details (application/problem+json): type (URI of the error " +
    "code), title, HTTP status, detail; RobWoT's stable code (E_...), message (= detail) and structured " +
    "details as extension members",
  properties: {
    type: { type: "string", format: "uri", description: `${PROBLEM_TYPE_BASE}<code>` },
    title: { type: "string", description: "short summary of the error code, the same for every occurrence" },
    status: { type: "integer", minimum: 400, maximum: 599, description: "the HTTP status of the answer" },
    detail: { type: "string", description: "what happened this time" },
    code: { type: "string", description: "stable error code, e.g. E_BAD_INPUT, E_BUSY, E_REJECTED" },
    message: { type: "string", description: "the same text as detail (the earlier body's member)" },
    details: { type: "object", description: "structured fields of the error (param, reasons, checks, ...)" },
  },
  required: ["type", "title", "status", "detail", "code", "message", "details"],
};
