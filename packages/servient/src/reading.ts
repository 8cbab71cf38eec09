/**
 * A reading of the physical robot, parsed strictly at the boundary: the exact joint set of the twin, each
 * a finite number (after the relay map's unit conversion, `relay-map.ts`), within the URDF limits up to a
 * small tolerance; anything else is a `ReadingError` naming the field, never a pose.
 *
 * Error texts are shown to every client (physicalState, /live, SSE), so whatever a hostile Thing sends is
 * described, never echoed: a value by its kind and size, at most `NAMED` unknown names (each cut to
 * `SNIPPET` characters) and how many more, the whole text cut to `MAX_ERROR_TEXT` bytes.
 */
import type { JointSpec } from "@robwot/core";

/** bytes (UTF-8): the longest error text about a reading that clients are shown */
export const MAX_ERROR_TEXT = 1024;
/** unknown names an error text lists before counting the rest */
const NAMED = 3;
/** characters of one name or string value quoted in an error text */
const SNIPPET = 40;
/** rad (revolute) and m (prismatic): a reading at most this far past a URDF limit is followed clamped to
 * it (a robot braking at its limit overshoots it a little, an encoder's zero is not exact); further is an
 * error */
export const LIMIT_TOLERANCE = { rad: 0.02, m: 0.002 } as const;

export class ReadingError extends Error {
  override name = "ReadingError";
  readonly code = "E_READING";

  constructor(
    /** the field of the reading that is wrong, e.g. `getJointPosition.lbr_iiwa_joint_1`, `actual_q[2]` */
    readonly field: string,
    why: string,
  ) {
    super(clip(`${field}: ${why}`));
  }
}

/** `text` cut to at most `max` UTF-8 bytes (marked with "..." when cut). */
export function clip(text: string, max = MAX_ERROR_TEXT): string {
  if (text.length <= max / 4 || Buffer.byteLength(text) <= max) return text;
  let bytes = 3;
  let out = "";
  for (const ch of text) {
    bytes += Buffer.byteLength(ch);
    if (bytes > max) break;
    out += ch;
  }
  return `${out}...`;
}

/** A name or string as a short JSON string literal. */
export function quote(s: string): string {
  if (s.length <= SNIPPET) return JSON.stringify(s);
  // never half a surrogate pair
  const cut = /[\uD800-\uDBFF]$/.test(s.slice(0, SNIPPET)) ? SNIPPET - 1 : SNIPPET;
  return `${JSON.stringify(s.slice(0, cut))}... (${s.length} characters)`;
}

/** What a value is, in a few words: its kind and size, short scalars as they are. */
export function describe(v: unknown): string {
  if (v === null) return "null";
  if (v === undefined) return "nothing";
  if (typeof v === "string") return `the string ${quote(v)}`;
  if (typeof v === "number" || typeof v === "boolean") return String(v);
  if (Array.isArray(v)) return `an array of ${v.length} item${v.length === 1 ? "" : "s"}`;
  if (typeof v === "object") return `an object of ${Object.keys(v).length} key(s)`;
  return `a ${typeof v}`;
}

/** At most `NAMED` names, quoted, and how many more. */
export function someNames(names: readonly string[]): string {
  const shown = names.slice(0, NAMED).map(quote).join(", ");
  return names.length > NAMED ? `${shown} and ${names.length - NAMED} more` : shown;
}

/** A joint vector (twin order) and, when the reading has one, the Thing's own time of it (ms). */
export interface Reading {
  record: Record<string, number>;
  timestamp?: number;
}

/**
 * A reading with the twin's own names (no relay map): an object of exactly the twin's joints, each a finite
 * number, and optionally `timestamp` (ISO 8601: when the Thing read its joints) unless a joint has that name.
 */
export function parseJointRecord(value: unknown, joints: readonly string[], property = "getJointPosition"): Reading {
  if (value === null || typeof value !== "object" || Array.isArray(value)) {
    throw new ReadingError(property, `expected an object of joint name -> number, got ${describe(value)}`);
  }
  const rec = value as Record<string, unknown>;
  const stamped = !joints.includes("timestamp") && Object.hasOwn(rec, "timestamp");
  const unknown = Object.keys(rec).filter((k) => !joints.includes(k) && !(stamped && k === "timestamp"));
  if (unknown.length > 0) throw new ReadingError(property, `${unknown.length} unknown joint(s) ${someNames(unknown)}; the twin's joints are ${someNames(joints)}`);
  const missing = joints.filter((j) => !Object.hasOwn(rec, j));
  if (missing.length > 0) throw new ReadingError(property, `missing joint(s) ${someNames(missing)}`);
  const record: Record<string, number> = {};
  for (const j of joints) {
    const v = rec[j];
    if (typeof v !== "number" || !Number.isFinite(v)) throw new ReadingError(`${property}.${j}`, `expected a finite number, got ${describe(v)}`);
    record[j] = v;
  }
  if (!stamped) return { record };
  const t = rec["timestamp"];
  const ms = typeof t === "string" && /^\d{4}-\d\d-\d\dT/.test(t) ? Date.parse(t) : NaN;
  if (!Number.isFinite(ms)) throw new ReadingError(`${property}.timestamp`, `expected an ISO 8601 date-time, got ${describe(t)}`);
  return { record, timestamp: ms };
}

/** Where a joint may be: its URDF limits, or anywhere for a continuous joint (read modulo a turn). */
export type JointRange = Pick<JointSpec, "name" | "type" | "lower" | "upper">;

/**
 * The joint vector within the joints' limits: a value past a limit by at most `LIMIT_TOLERANCE` is clamped
 * to it (`clamped` keeps what was read), a continuous joint's angle taken into [-pi, pi]; a value further
 * past is a `ReadingError` naming the joint, the value and the limits.
 */
export function withinLimits(q: readonly number[], ranges: readonly (JointRange | undefined)[], property = "getJointPosition"): { q: number[]; clamped: Record<string, number> } {
  const clamped: Record<string, number> = {};
  const out = q.map((v, i) => {
    const r = ranges[i];
    if (!r) return v;
    if (r.type === "continuous") return v - 2 * Math.PI * Math.round(v / (2 * Math.PI));
    if (v >= r.lower && v <= r.upper) return v;
    const unit = r.type === "prismatic" ? "m" : "rad";
    if (v < r.lower - LIMIT_TOLERANCE[unit] || v > r.upper + LIMIT_TOLERANCE[unit]) {
      throw new ReadingError(`${property}.${r.name}`, `${v} ${unit} is beyond its limits [${r.lower}, ${r.upper}] by more than ${LIMIT_TOLERANCE[unit]} ${unit}: the twin's model cannot show this robot`);
    }
    clamped[r.name] = v;
    return Math.min(r.upper, Math.max(r.lower, v));
  });
  return { q: out, clamped };
}
