/**
 * `--relay-map FILE`: how a physical robot's Thing that does not use the twin's affordance names is read
 * and commanded (a vendor's TD: a UR-style `actual_q` array in degrees, a `movej` action, `stopj`). JSON:
 *
 *   {
 *     "joints": ["shoulder_pan_joint", ...],        the twin's joint names, in the physical Thing's order
 *     "unit": "deg",                                  "rad" (default) or "deg": angles of revolute joints
 *     "jointState": "actual_q",                       property: an array of the joints, in that order
 *     "moveJoints": {"action": "movej", "joints": "q", "speed": "v"},   input {q: [...], v: speed fraction}
 *     "moveCartesian": {"action": "movel", "speed": "v"},               input {x, y, z, orientation?, v}
 *     "stop": "stopj"                                 action without input
 *   }
 *
 * `moveCartesian` is optional (a Cartesian command is then refused by the relay, naming the map). Without a
 * map the twin's own names are used. The file is checked when serve starts: a mistake is refused naming the
 * file and the field.
 */
import { readFileSync } from "node:fs";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { describe, ReadingError } from "./reading.js";

export interface RelayMap {
  joints: string[];
  unit: "rad" | "deg";
  jointState: string;
  moveJoints: { action: string; joints: string; speed?: string };
  moveCartesian?: { action: string; speed?: string };
  stop: string;
}

export class RelayMapError extends Error {}

const DEG = Math.PI / 180;

/** Reads and checks a relay map against the twin's joint names. */
export function loadRelayMap(file: string, twinJoints: readonly string[]): RelayMap {
  let doc: unknown;
  try {
    doc = JSON.parse(readFileSync(file, "utf8"));
  } catch (err) {
    throw new RelayMapError(`${file}: not a JSON file: ${err instanceof Error ? err.message : String(err)}`);
  }
  const fail = (field: string, why: string): never => {
    throw new RelayMapError(`${file}: ${field}: ${why}`);
  };
  if (doc === null || typeof doc !== "object" || Array.isArray(doc)) fail("(top)", "expected an object");
  const d = doc as Record<string, unknown>;
  const known = ["joints", "unit", "jointState", "moveJoints", "moveCartesian", "stop"];
  for (const k of Object.keys(d)) if (!known.includes(k)) fail(k, `unknown field (known: ${known.join(", ")})`);
  const { minLength, maxLength } = VALUE_SCHEMAS.Name;
  const name = (field: string, v: unknown): string =>
    typeof v === "string" && v.length >= minLength && v.length <= maxLength ? v : fail(field, `expected a name (${minLength}-${maxLength} characters)`);
  const joints = Array.isArray(d["joints"]) ? d["joints"].map((j, i) => name(`joints[${i}]`, j)) : fail("joints", "expected an array of the twin's joint names");
  const missing = twinJoints.filter((j) => !joints.includes(j));
  const unknown = joints.filter((j) => !twinJoints.includes(j));
  if (unknown.length > 0) fail("joints", `not joints of the twin: ${unknown.join(", ")} (its joints: ${twinJoints.join(", ")})`);
  if (missing.length > 0 || joints.length !== twinJoints.length) fail("joints", `every joint of the twin exactly once (missing: ${missing.join(", ") || "none"})`);
  const unit = d["unit"] ?? "rad";
  if (unit !== "rad" && unit !== "deg") fail("unit", `"rad" or "deg", got ${JSON.stringify(unit)}`);
  const action = (field: string, withJoints: boolean): { action: string; joints: string; speed?: string } => {
    const v = d[field];
    if (v === null || typeof v !== "object" || Array.isArray(v)) return fail(field, "expected an object {action, ...}");
    const o = v as Record<string, unknown>;
    return {
      action: name(`${field}.action`, o["action"]),
      joints: withJoints ? name(`${field}.joints`, o["joints"]) : "",
      ...(o["speed"] !== undefined ? { speed: name(`${field}.speed`, o["speed"]) } : {}),
    };
  };
  const cartesian = d["moveCartesian"] !== undefined ? action("moveCartesian", false) : undefined;
  return {
    joints,
    unit: unit as "rad" | "deg",
    jointState: name("jointState", d["jointState"]),
    moveJoints: action("moveJoints", true),
    ...(cartesian ? { moveCartesian: { action: cartesian.action, ...(cartesian.speed ? { speed: cartesian.speed } : {}) } } : {}),
    stop: name("stop", d["stop"]),
  };
}

/**
 * The twin's joint record from the physical Thing's joint state: exactly an array of the map's joints, each
 * a finite number also after the unit conversion; anything else is a `ReadingError` naming the field
 * (`actual_q`, `actual_q[2]`), never a pose.
 */
export function jointsFromPhysical(map: RelayMap, value: unknown): Record<string, number> {
  const n = map.joints.length;
  if (!Array.isArray(value)) throw new ReadingError(map.jointState, `expected an array of ${n} numbers, got ${describe(value)}`);
  if (value.length !== n) throw new ReadingError(map.jointState, `expected an array of ${n} numbers (the map's joints), got ${describe(value)}`);
  const k = map.unit === "deg" ? DEG : 1;
  const out: Record<string, number> = {};
  map.joints.forEach((j, i) => {
    const v: unknown = value[i];
    const field = `${map.jointState}[${i}]`;
    if (typeof v !== "number" || !Number.isFinite(v)) throw new ReadingError(field, `${j}: expected a finite number, got ${describe(v)}`);
    const x = v * k;
    if (!Number.isFinite(x)) throw new ReadingError(field, `${j}: ${v} ${map.unit} is not a finite number of rad`);
    out[j] = x;
  });
  return out;
}

/** The physical Thing's action and input for one of the twin's relayed actions. */
export function toPhysical(map: RelayMap, action: string, input: unknown): { action: string; input: unknown } {
  const i = (input ?? {}) as Record<string, unknown>;
  const speed = (field: string | undefined): Record<string, unknown> => (field && i["speed"] !== undefined ? { [field]: i["speed"] } : {});
  if (action === "stop") return { action: map.stop, input: undefined };
  if (action === "moveToJointPosition") {
    const joints = (i["joints"] ?? {}) as Record<string, number>;
    const k = map.unit === "deg" ? 1 / DEG : 1;
    return { action: map.moveJoints.action, input: { [map.moveJoints.joints]: map.joints.map((j) => (joints[j] ?? 0) * k), ...speed(map.moveJoints.speed) } };
  }
  if (action === "moveToCartesianPosition") {
    if (!map.moveCartesian) throw new Error("the relay map names no Cartesian move (moveCartesian): the physical robot cannot take this command");
    const { speed: _s, ...pose } = i;
    return { action: map.moveCartesian.action, input: { ...pose, ...speed(map.moveCartesian.speed) } };
  }
  throw new Error(`the relay map has no counterpart of ${action}`);
}
