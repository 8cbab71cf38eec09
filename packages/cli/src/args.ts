/** Small parsers for option values; each throws a `CliError` naming the option and the bad value. */
import { existsSync, statSync } from "node:fs";
import { resolve } from "node:path";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { CliError } from "./errors.js";

export function parseInteger(option: string, value: string | undefined, fallback: number, min: number, max = Number.MAX_SAFE_INTEGER): number {
  if (value === undefined) return fallback;
  if (!/^[+]?\d+$/.test(value.trim())) throw new CliError(`--${option} must be an integer, got "${value}"`);
  const n = Number(value);
  if (n < min || n > max) throw new CliError(`--${option} must be between ${min} and ${max}, got ${n}`);
  return n;
}

export function parseNumber(option: string, value: string | undefined, fallback: number, min: number, max = Number.POSITIVE_INFINITY): number {
  if (value === undefined) return fallback;
  const n = Number(value);
  if (value.trim() === "" || !Number.isFinite(n)) throw new CliError(`--${option} must be a number, got "${value}"`);
  if (n < min || n > max) throw new CliError(`--${option} must be between ${min} and ${max}, got ${n}`);
  return n;
}

/** `--realtime`: 0 (as fast as possible) or a factor within the backend contract's `RealtimeFactor`. */
export function parseRealtime(value: string | undefined): number {
  const { minimum, maximum } = VALUE_SCHEMAS.RealtimeFactor;
  const n = parseNumber("realtime", value, 1, 0, maximum);
  if (n > 0 && n < minimum) throw new CliError(`--realtime must be 0 (as fast as possible) or between ${minimum} and ${maximum}, got ${n}`);
  return n;
}

export function parseAlpha(value: string | undefined): "auto" | number {
  if (value === undefined || value === "auto") return "auto";
  const n = Number(value);
  if (value.trim() === "" || !Number.isFinite(n) || n <= 0) {
    throw new CliError(`--alpha must be "auto" or a positive radius in metres, got "${value}"`);
  }
  return n;
}

/** `--package-root NAME=DIR` (repeatable) → `{NAME: absolute DIR}`; the folder must exist. */
export function parsePackageRoots(values: string[] | undefined): Record<string, string> {
  const roots: Record<string, string> = {};
  for (const v of values ?? []) {
    const eq = v.indexOf("=");
    const name = eq > 0 ? v.slice(0, eq) : "";
    const dir = eq > 0 ? v.slice(eq + 1) : "";
    if (!/^[A-Za-z0-9_.-]+$/.test(name) || dir === "") {
      throw new CliError(`--package-root must look like NAME=DIR (e.g. ur_description=./ur_description), got "${v}"`);
    }
    const abs = resolve(dir);
    if (!existsSync(abs) || !statSync(abs).isDirectory()) {
      throw new CliError(`--package-root ${name}: folder not found: ${abs}`);
    }
    roots[name] = abs;
  }
  return roots;
}

/**
 * A URL option of one of `protocols`. A URL the user's credentials may travel in (`userinfo: "send"`: a
 * peer the servient requests, which moves them into an Authorization header) may carry them; one written
 * into a document or a property (`"refuse"`, the default) may not: it would publish them.
 */
export function parseUrl(option: string, value: string | undefined, protocols: string[], userinfo: "send" | "refuse" = "refuse"): URL | undefined {
  if (value === undefined) return undefined;
  let url: URL;
  try {
    url = new URL(value);
  } catch {
    throw new CliError(`--${option} must be a URL (${protocols.join(" or ")}), got "${value}"`);
  }
  if (!protocols.includes(url.protocol.replace(/:$/, ""))) {
    throw new CliError(`--${option} must use ${protocols.join(" or ")}, got "${value}"`);
  }
  if (userinfo === "refuse" && (url.username || url.password)) {
    throw new CliError(`--${option} must not carry credentials (user:password@): it is written where others read it`);
  }
  return url;
}

/** A file argument that must exist and be a regular file. */
export function existingFile(what: string, path: string): string {
  const abs = resolve(path);
  if (!existsSync(abs)) throw new CliError(`${what} not found: ${abs}`, "E_FILE_NOT_FOUND");
  if (!statSync(abs).isFile()) throw new CliError(`${what} is not a file: ${abs}`, "E_FILE_NOT_FOUND");
  return abs;
}

/** Edit distance (insert, delete, substitute, swap of neighbours) between two short strings. */
function distance(a: string, b: string): number {
  const d = Array.from({ length: a.length + 1 }, (_, i) => Array.from({ length: b.length + 1 }, (_, j) => (i === 0 ? j : j === 0 ? i : 0)));
  for (let i = 1; i <= a.length; i++) {
    for (let j = 1; j <= b.length; j++) {
      const row = d[i]!;
      const cost = a[i - 1] === b[j - 1] ? 0 : 1;
      row[j] = Math.min(d[i - 1]![j]! + 1, row[j - 1]! + 1, d[i - 1]![j - 1]! + cost);
      if (i > 1 && j > 1 && a[i - 1] === b[j - 2] && a[i - 2] === b[j - 1]) row[j] = Math.min(row[j]!, d[i - 2]![j - 2]! + 1);
    }
  }
  return d[a.length]![b.length]!;
}

/**
 * node's `parseArgs` errors span several lines: one line, pointing at the command's help. An unknown
 * option (`--sampels`) is named with the closest of `known` (the command's option names) when one is close.
 */
export function usageError(err: unknown, command: string, known: string[] = []): CliError {
  const message = (err as Error).message;
  const unknown = /^Unknown option '(-{1,2}[^']+)'/.exec(message)?.[1];
  if (unknown !== undefined) {
    const name = unknown.replace(/^-+/, "").split("=")[0] ?? "";
    const best = known.map((k) => ({ k, d: distance(name, k) })).sort((x, y) => x.d - y.d)[0];
    const prefixed = name.length >= 3 ? known.find((k) => k.startsWith(name)) : undefined;
    const close = best && best.d <= Math.max(1, Math.floor(name.length / 3)) ? best.k : prefixed;
    const guess = close !== undefined ? `did you mean --${close}?; ` : "";
    return new CliError(`unknown option ${unknown} (${guess}see robwot ${command} --help)`);
  }
  return new CliError(`${message.replace(/\s*\n\s*/g, " ")} (see robwot ${command} --help)`);
}
