/**
 * The TD 1.1 Thing Model of every RobWoT robot-arm twin (`tm:ThingModel`): the affordances and data
 * schemas all twins share, with placeholders for what differs per robot — its name and end effector
 * (`{{ROBOT_NAME}}`, `{{EE_LINK}}`), its joints (one number per controllable joint, named as in the
 * URDF) and the Cartesian bounds of its workspace (`{{X_MIN}}` ... `{{Z_MAX}}`). `robwot generate`
 * writes it as `robot-arm.tm.json` into each twin folder, and each TD links it with `rel: "type"`.
 * Built from the TD builder itself, so the two cannot drift apart.
 */
import { buildThingDescription } from "./build.js";
import type { DataSchema } from "./types.js";

type Json = Record<string, unknown>;

const JOINTS_SCHEMA: DataSchema = {
  type: "object",
  description: "one number per controllable joint of {{ROBOT_NAME}}, named as in its URDF, within the joint's limits (rad or m); joints that follow others (the TD's robwot:couplings: mimic joints, parallel-linkage joints) are not among them",
};

export function buildThingModel(): Json {
  const placeholderModel = {
    name: "robot",
    eeLink: "tool",
    controllable: ["joint"],
    joints: [{ name: "joint", type: "revolute" as const, lower: -1, upper: 1, velocity: 1, effort: 1 }],
  };
  const td = buildThingDescription({ model: placeholderModel, summary: null, liveUrl: null }) as unknown as Json;
  const tm: Json = {
    "@context": td["@context"],
    "@type": "tm:ThingModel",
    // every instance conforms to the WoT Profiles (HTTP Basic, HTTP SSE) its TD declares
    profile: td["profile"],
    title: "{{ROBOT_NAME}}",
    description:
      "Web of Things digital twin of a robot arm ({{ROBOT_NAME}}, end effector {{EE_LINK}}) made by RobWoT from its URDF: " +
      "joint and Cartesian state, validated joint and Cartesian moves, stop, calibration, scene edits, collision events.",
    version: { model: "1.0.0" },
  };
  for (const kind of ["properties", "actions", "events"] as const) {
    const group: Record<string, Json> = {};
    for (const [name, a] of Object.entries((td[kind] ?? {}) as Record<string, Json>)) {
      const { forms: _forms, ...rest } = a;
      group[name] = rest;
    }
    tm[kind] = group;
  }
  const actions = tm.actions as Record<string, Json>;
  for (const name of ["moveToCartesianPosition", "validateCartesianPosition"]) {
    const input = (actions[name]?.input ?? {}) as Json;
    for (const axis of ["x", "y", "z"]) {
      const s = (input.properties as Record<string, Json> | undefined)?.[axis];
      if (!s) continue;
      const upper = axis.toUpperCase();
      s.minimum = `{{${upper}_MIN}}`;
      s.maximum = `{{${upper}_MAX}}`;
    }
  }
  return withJointPlaceholders(tm) as Json;
}

/** Every per-joint object schema of the placeholder robot (its one joint is named "joint") replaced by
 * the generic joints schema; other fields of that schema (title, readOnly, ...) kept. */
function withJointPlaceholders(v: unknown): unknown {
  if (Array.isArray(v)) return v.map(withJointPlaceholders);
  if (v === null || typeof v !== "object") return v;
  const o = v as Json;
  const props = o.properties as Json | undefined;
  if (o.type === "object" && props && Object.keys(props).length === 1 && "joint" in props) {
    const { properties: _p, required: _r, additionalProperties: _a, ...rest } = o;
    return { ...rest, ...JOINTS_SCHEMA };
  }
  return Object.fromEntries(Object.entries(o).map(([k, x]) => [k, withJointPlaceholders(x)]));
}
