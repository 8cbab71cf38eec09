/**
 * CLI errors. Every failure the user can cause ends as one line `robwot: error: <message>` on stderr and a
 * non-zero exit code; the message names the file, line, joint, link or value involved.
 */

import { RobwotError } from "@robwot/core/errors";

/** An error whose message is ready to show to the user: a RobwotError (string `code`: `E_USAGE`,
 *  `E_OUTPUT`, or the backend's `E_...` code) with the process exit code (2 usage, 1 otherwise). */
export class CliError extends RobwotError {
  override name = "CliError";
  readonly exitCode: number;
  constructor(message: string, code = "E_USAGE", exitCode: number = code === "E_USAGE" ? 2 : 1) {
    super(code, message);
    this.exitCode = exitCode;
  }
}

const DETAIL_FIELDS = ["file", "line", "column", "joint", "value", "lower", "upper", "param", "expected", "got", "path", "name", "urdf"];

function fmtValue(v: unknown): string {
  if (typeof v === "string") return v;
  if (typeof v === "number") return String(v);
  return JSON.stringify(v);
}

/**
 * Turns any thrown value into a one-line message. Backend (JSON-RPC) errors keep their message and get
 * their structured fields appended when the message does not already mention them.
 */
export function describeError(err: unknown): { message: string; code: string; exitCode: number } {
  if (err instanceof CliError) return { message: err.message, code: err.code, exitCode: err.exitCode };
  if (err instanceof RobwotError) {
    // a backend (JSON-RPC) error carries its `error.data` as `details`, `data.code` as `code`
    const data = err.details;
    let message = err.message;
    const extra: string[] = [];
    for (const k of DETAIL_FIELDS) {
      const v = data[k];
      if (v === undefined || v === null) continue;
      const s = fmtValue(v);
      if (!message.includes(s)) extra.push(`${k}=${s}`);
    }
    const available = data["available"];
    if (Array.isArray(available) && !/valid|available/i.test(message)) {
      extra.push(`valid: ${available.map(fmtValue).join(", ")}`);
    }
    if (extra.length > 0) message += ` (${extra.join(", ")})`;
    return { message, code: err.code, exitCode: 1 };
  }
  if (err instanceof Error) return { message: err.message, code: "E_INTERNAL", exitCode: 1 };
  return { message: String(err), code: "E_INTERNAL", exitCode: 1 };
}
