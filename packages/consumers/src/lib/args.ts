/**
 * Tiny command-line parsing shared by the scenarios: positional arguments (TD URLs) and
 * `--name value` / `--flag` options. Unknown options are an error naming the valid ones.
 */
import { MIN_SPEED, RobwotError } from "@robwot/core";

export interface ParsedArgs {
  positional: string[];
  options: Map<string, string | true>;
}

export class UsageError extends RobwotError {
  override name = "UsageError";
  constructor(message: string) {
    super("E_USAGE", message);
  }
}

export function parseArgs(argv: string[], known: Record<string, "value" | "flag">): ParsedArgs {
  const positional: string[] = [];
  const options = new Map<string, string | true>();
  for (let i = 0; i < argv.length; i++) {
    const arg = argv[i] as string;
    if (!arg.startsWith("--")) {
      positional.push(arg);
      continue;
    }
    const eq = arg.indexOf("=");
    const name = arg.slice(2, eq === -1 ? undefined : eq);
    const kind = known[name];
    if (kind === undefined) {
      const valid = Object.keys(known).map((k) => `--${k}`).join(", ");
      throw new UsageError(`unknown option --${name} (valid: ${valid || "none"})`);
    }
    if (kind === "flag") {
      options.set(name, true);
    } else if (eq !== -1) {
      options.set(name, arg.slice(eq + 1));
    } else {
      const value = argv[++i];
      if (value === undefined) throw new UsageError(`option --${name} needs a value`);
      options.set(name, value);
    }
  }
  return { positional, options };
}

export function numberOption(args: ParsedArgs, name: string, fallback: number, min: number, max: number): number {
  const raw = args.options.get(name);
  if (raw === undefined) return fallback;
  const value = Number(raw);
  if (raw === true || !Number.isFinite(value) || value < min || value > max) {
    throw new UsageError(`--${name} must be a number in [${min}, ${max}], got ${String(raw)}`);
  }
  return value;
}

/** `--speed`: a fraction of the URDF velocity limits within the range every move action accepts. */
export function speedOption(args: ParsedArgs, fallback: number): number {
  return numberOption(args, "speed", fallback, MIN_SPEED, 1);
}

export function stringOption(args: ParsedArgs, name: string): string | undefined {
  const raw = args.options.get(name);
  if (raw === true) throw new UsageError(`option --${name} needs a value`);
  return raw;
}
