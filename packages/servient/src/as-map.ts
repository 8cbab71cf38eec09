/**
 * `robwot serve TWIN --as DEVICE=real-td.json [--as-map map.json]`: the files that say which physical
 * device the twin answers as (its own TD) and how each of its affordances maps onto the twin's. Both files
 * are hostile input: read whole within a size cap or refused, their JSON nesting bounded, every key known,
 * every name a plain URL path segment; a mistake is an `AsDeviceError` naming the file and the field, at
 * start, before the backend starts. The map format (README "Serving a real device's TD"):
 *
 *   {
 *     "frame": {"scale": 0.001, "offset": [0.4, 0, 0.35]},   device x,y,z * scale + offset = the twin's (m)
 *     "orientation": "keep" | "free" | {"x","y","z","w"},    of every Cartesian move (default "keep")
 *     "actions": {
 *       "goTo":   {"twin": "moveToCartesianPosition", "speed": 0.5},
 *       "go":     {"twin": "moveToCartesianPosition", "speed": {"field": "speed", "max": FULL}},   speed / FULL
 *       "goHome": {"twin": "moveToJointPosition", "joints": "home"},
 *       "gripOpen": {"twin": "gripOpen"},                  the twin's action of that name, input as is
 *       "beep": "unsupported",                              kept in the TD, answers 501
 *       "getCube": {"sequence": [                           a device action without input: the twin's
 *         {"twin": "moveToCartesianPosition", "position": {"x": 0, "y": 0, "z": 100}},   actions in order,
 *         {"twin": "gripClose"}, {"twin": "moveToJointPosition", "joints": "home"}]}     the first refusal ends it
 *     },
 *     "properties": {"location": {"twin": "getCartesianPosition"}, "homeLoc": "unsupported"},
 *     "events": {"alarm": "unsupported"},                   dropped from the served TD
 *     "twin": "uarm_like"                                   the twin answering (with several twin folders)
 *   }
 *
 * Every affordance of the device's TD needs an entry. Without a map, `defaultAsMap` infers one by name and
 * shape (see there) and refuses, naming them, the affordances it cannot infer.
 */
import { readFileSync, statSync } from "node:fs";
import { jsonErrorAt, MIN_SPEED, type Quaternion } from "@robwot/core";
import { jsonDepth } from "./request-guard.js";
import type { TdDocument } from "./twin-folder.js";

export type Json = Record<string, unknown>;

/** The device's TD file: bytes, nesting, affordances of each kind. */
export const AS_TD_LIMITS = { bytes: 1 << 20, depth: 32, affordances: 256 } as const;
/** The map file: bytes, nesting. */
export const AS_MAP_LIMITS = { bytes: 64 << 10, depth: 8 } as const;
/** The twin's move actions a map entry may name with a conversion; any other twin name is passed through. */
export const CARTESIAN_MOVE = "moveToCartesianPosition";
export const JOINT_MOVE = "moveToJointPosition";
export const POSE_PROPERTY = "getCartesianPosition";
const KINDS = ["actions", "properties", "events"] as const;
type Kind = (typeof KINDS)[number];
const ONE: Record<Kind, string> = { actions: "action", properties: "property", events: "event" };
const AXES = ["x", "y", "z"] as const;
/** A device affordance name becomes a URL path segment: plain characters, never an object's own key. */
const NAME = /^[A-Za-z0-9_.~-]{1,64}$/;
const FORBIDDEN_NAMES = new Set(["__proto__", "constructor", "prototype"]);
/** Units of the device's coordinates (the schema's `unit`) and their metres. */
const UNITS: Record<string, number> = { mm: 0.001, millimetre: 0.001, millimeter: 0.001, cm: 0.01, m: 1, metre: 1, meter: 1 };

export class AsDeviceError extends Error {
  override name = "AsDeviceError";
}

export interface Frame {
  scale: number;
  offset: [number, number, number];
}
export type SpeedRule = number | { field: string; max: number };
/** One of the twin's actions a device action maps to. */
export type TwinRule =
  | { kind: "cartesian"; speed?: SpeedRule }
  | { kind: "joints"; joints: "home" | Record<string, number>; speed?: number }
  | { kind: "direct"; twin: string };
/** A step of a sequence: a rule and its fixed input (a Cartesian step's position, in the device's units). */
export interface SequenceStep {
  rule: TwinRule;
  position?: { x: number; y: number; z: number };
}
export type ActionRule = { kind: "unsupported" } | TwinRule | { kind: "sequence"; steps: SequenceStep[] };
export type PropertyRule = { kind: "unsupported" } | { kind: "position" } | { kind: "direct"; twin: string };

export interface AsMap {
  /** where the map came from: its file, or "the default map" */
  source: string;
  frame: Frame | null;
  orientation: "keep" | "free" | Quaternion;
  actions: Map<string, ActionRule>;
  properties: Map<string, PropertyRule>;
  /** the device's events, each "unsupported" (dropped from the served TD) */
  events: Set<string>;
  /** the twin (its URL path segment) that answers as the device; null: the one twin served */
  twin: string | null;
}

/** Steps of one sequence at most. */
export const MAX_SEQUENCE_STEPS = 32;

const isObject = (v: unknown): v is Json => v !== null && typeof v === "object" && !Array.isArray(v);
const said = (v: unknown): string => (typeof v === "string" ? JSON.stringify(v.slice(0, 40)) : v === null ? "null" : Array.isArray(v) ? "an array" : typeof v);

/** A JSON file read whole within `limits` (size before and after reading, nesting) or refused naming it. */
export function readJsonFile(file: string, what: string, limits: { bytes: number; depth: number }): unknown {
  const fail = (why: string): never => {
    throw new AsDeviceError(`${file}: ${why}`);
  };
  let size = 0;
  try {
    const st = statSync(file);
    if (!st.isFile()) fail(`not a regular file (${what})`);
    size = st.size;
  } catch (err) {
    if (err instanceof AsDeviceError) throw err;
    fail(`cannot be read (${what}): ${(err as NodeJS.ErrnoException).code ?? String(err)}`);
  }
  if (size > limits.bytes) fail(`${size} bytes, more than a ${what} may have (${limits.bytes})`);
  const text = readFileSync(file, "utf8");
  // the file may have grown between the two calls
  if (Buffer.byteLength(text) > limits.bytes) fail(`more than ${limits.bytes} bytes, the most a ${what} may have`);
  const depth = jsonDepth(text);
  if (depth > limits.depth) fail(`JSON nested ${depth} levels deep, more than a ${what} may be (${limits.depth})`);
  try {
    return JSON.parse(text) as unknown;
  } catch (err) {
    return fail(`not JSON (${what})${jsonErrorAt(err, text)}`);
  }
}

/** The device's TD: an object with a title, each affordance kind an object of objects with plain names. */
export function checkDeviceTd(file: string, doc: unknown): TdDocument {
  const fail = (field: string, why: string): never => {
    throw new AsDeviceError(`${file}: ${field}: ${why}`);
  };
  if (!isObject(doc)) return fail("(top)", `expected a Thing Description (a JSON object), got ${said(doc)}`);
  if (typeof doc["title"] !== "string" || doc["title"].trim() === "") fail("title", "expected a non-empty string");
  for (const kind of KINDS) {
    const v = doc[kind];
    if (v === undefined) continue;
    if (!isObject(v)) fail(kind, `expected an object of affordances, got ${said(v)}`);
    const names = Object.keys(v as Json);
    if (names.length > AS_TD_LIMITS.affordances) fail(kind, `${names.length} affordances, more than ${AS_TD_LIMITS.affordances}`);
    for (const n of names) {
      if (!NAME.test(n) || FORBIDDEN_NAMES.has(n)) fail(`${kind}.${n.slice(0, 40)}`, "not a plain name (1-64 of A-Z a-z 0-9 _ . ~ -): it becomes a URL path segment");
      if (!isObject((v as Json)[n])) fail(`${kind}.${n}`, `expected an object, got ${said((v as Json)[n])}`);
    }
  }
  if (!isObject(doc["actions"]) && !isObject(doc["properties"])) fail("(top)", "the device describes no property and no action");
  return doc as TdDocument;
}

const affordances = (td: TdDocument, kind: Kind): Record<string, Json> => ((td as Json)[kind] ?? {}) as Record<string, Json>;

/** The object schema of an action's input or a property, or null. */
const objectSchema = (s: unknown): Record<string, Json> | null => (isObject(s) && isObject(s["properties"]) ? (s["properties"] as Record<string, Json>) : null);
const isNumeric = (s: Json | undefined): boolean => s?.["type"] === "number" || s?.["type"] === "integer";
const hasPosition = (props: Record<string, Json> | null): props is Record<string, Json> => props !== null && AXES.every((a) => isNumeric(props[a]));

/** Parses the map file (`readJsonFile` first); names are checked against the TDs by `checkAsMap`. */
export function parseAsMap(file: string, doc: unknown): AsMap {
  const fail = (field: string, why: string): never => {
    throw new AsDeviceError(`${file}: ${field}: ${why}`);
  };
  if (!isObject(doc)) return fail("(top)", `expected a JSON object, got ${said(doc)}`);
  const known = ["frame", "orientation", "twin", ...KINDS];
  for (const k of Object.keys(doc)) if (!known.includes(k)) fail(k.slice(0, 40), `unknown field (known: ${known.join(", ")})`);
  const map: AsMap = { source: file, frame: null, orientation: "keep", actions: new Map(), properties: new Map(), events: new Set(), twin: null };
  if (doc["twin"] !== undefined) {
    if (typeof doc["twin"] !== "string" || !NAME.test(doc["twin"])) fail("twin", `the URL path segment of the twin that answers as the device, got ${said(doc["twin"])}`);
    map.twin = doc["twin"] as string;
  }
  if (doc["frame"] !== undefined) map.frame = parseFrame(doc["frame"], fail);
  if (doc["orientation"] !== undefined) map.orientation = parseOrientation(doc["orientation"], fail);
  for (const kind of KINDS) {
    const entries = doc[kind];
    if (entries === undefined) continue;
    if (!isObject(entries)) fail(kind, `expected an object of the device's ${kind} by name, got ${said(entries)}`);
    for (const [name, entry] of Object.entries(entries as Json)) {
      const field = `${kind}.${name.slice(0, 64)}`;
      if (!NAME.test(name) || FORBIDDEN_NAMES.has(name)) fail(field, "not a plain affordance name");
      if (kind === "events") {
        if (entry !== "unsupported") fail(field, `an event can only be "unsupported" (it is left out of the served TD), got ${said(entry)}`);
        map.events.add(name);
      } else if (kind === "actions") map.actions.set(name, parseActionRule(entry, field, fail));
      else map.properties.set(name, parsePropertyRule(entry, field, fail));
    }
  }
  return map;
}

type Fail = (field: string, why: string) => never;

function parseFrame(v: unknown, fail: Fail): Frame {
  if (!isObject(v)) return fail("frame", `expected {"scale", "offset"?}, got ${said(v)}`);
  for (const k of Object.keys(v)) if (k !== "scale" && k !== "offset") fail(`frame.${k.slice(0, 40)}`, "unknown field (known: scale, offset)");
  const scale = v["scale"];
  if (typeof scale !== "number" || !Number.isFinite(scale) || scale <= 0 || scale > 1000) fail("frame.scale", `metres per device unit, a number in (0, 1000] (0.001 for millimetres), got ${said(scale)}`);
  const offset = v["offset"] ?? [0, 0, 0];
  if (!Array.isArray(offset) || offset.length !== 3 || !offset.every((x) => typeof x === "number" && Number.isFinite(x) && Math.abs(x) <= 100)) {
    fail("frame.offset", "expected [x, y, z] in metres (each within 100 m): the device's origin in the twin's frame");
  }
  return { scale: scale as number, offset: offset as [number, number, number] };
}

function parseOrientation(v: unknown, fail: Fail): AsMap["orientation"] {
  if (v === "keep" || v === "free") return v;
  if (!isObject(v)) return fail("orientation", `"keep" (the twin's current orientation), "free" (position only) or a unit quaternion {x, y, z, w}, got ${said(v)}`);
  for (const k of Object.keys(v)) if (!["x", "y", "z", "w"].includes(k)) fail(`orientation.${k.slice(0, 40)}`, "unknown field (a quaternion: x, y, z, w)");
  const q = ["x", "y", "z", "w"].map((k) => v[k]);
  if (!q.every((x) => typeof x === "number" && Number.isFinite(x))) fail("orientation", "a quaternion needs four finite numbers x, y, z, w");
  const n = Math.hypot(...(q as number[]));
  if (Math.abs(n - 1) > 1e-3) fail("orientation", `a unit quaternion, its norm is ${n.toPrecision(4)}`);
  const [x, y, z, w] = (q as number[]).map((c) => c / n) as [number, number, number, number];
  return { x, y, z, w };
}

function parseSpeed(v: unknown, field: string, fail: Fail): SpeedRule {
  if (typeof v === "number") {
    if (!Number.isFinite(v) || v < MIN_SPEED || v > 1) fail(`${field}.speed`, `a fraction of the twin's joint speed limits in [${MIN_SPEED}, 1], got ${v}`);
    return v;
  }
  if (!isObject(v)) return fail(`${field}.speed`, `a fraction in [${MIN_SPEED}, 1] or {"field": NAME, "max": NUMBER} (the device's speed input / max = the fraction), got ${said(v)}`);
  for (const k of Object.keys(v)) if (k !== "field" && k !== "max") fail(`${field}.speed.${k.slice(0, 40)}`, "unknown field (known: field, max)");
  if (typeof v["field"] !== "string" || !NAME.test(v["field"])) fail(`${field}.speed.field`, "the name of the device's speed input field");
  const max = v["max"];
  if (typeof max !== "number" || !Number.isFinite(max) || max <= 0) fail(`${field}.speed.max`, `the device's speed value of the twin's full speed, a positive number, got ${said(max)}`);
  return { field: v["field"] as string, max: max as number };
}

function parseActionRule(v: unknown, field: string, fail: Fail): ActionRule {
  if (v === "unsupported") return { kind: "unsupported" };
  if (!isObject(v)) return fail(field, `expected {"twin": ACTION, ...}, {"sequence": [...]} or "unsupported", got ${said(v)}`);
  if (v["sequence"] !== undefined) return parseSequence(v, field, fail);
  return parseTwinRule(v, field, fail);
}

/** `{"sequence": [{"twin": ACTION, "position"?: {x, y, z}, ...}, ...]}`: at most `MAX_SEQUENCE_STEPS`. */
function parseSequence(v: Json, field: string, fail: Fail): ActionRule {
  for (const k of Object.keys(v)) if (k !== "sequence") fail(`${field}.${k.slice(0, 40)}`, "unknown field (known: sequence)");
  const steps = v["sequence"];
  if (!Array.isArray(steps) || steps.length === 0 || steps.length > MAX_SEQUENCE_STEPS) {
    return fail(`${field}.sequence`, `1 to ${MAX_SEQUENCE_STEPS} steps, each {"twin": ACTION, ...}, got ${said(steps)}`);
  }
  return {
    kind: "sequence",
    steps: steps.map((step: unknown, k) => {
      const at = `${field}.sequence[${k}]`;
      if (!isObject(step)) return fail(at, `expected {"twin": ACTION, ...}, got ${said(step)}`);
      const { position, ...rest } = step;
      const rule = parseTwinRule(rest, at, fail);
      if ((rule.kind === "cartesian") !== (position !== undefined)) fail(`${at}.position`, "a moveToCartesianPosition step needs a position {x, y, z} in the device's units; no other step takes one");
      if (rule.kind === "cartesian" && typeof rule.speed === "object") fail(`${at}.speed`, "a step takes a fixed speed fraction");
      if (position === undefined) return { rule };
      if (!isObject(position) || Object.keys(position).length !== 3 || !AXES.every((a) => typeof position[a] === "number" && Number.isFinite(position[a]))) {
        return fail(`${at}.position`, `expected {x, y, z}: finite numbers in the device's units, got ${said(position)}`);
      }
      return { rule, position: { x: position["x"] as number, y: position["y"] as number, z: position["z"] as number } };
    }),
  };
}

function parseTwinRule(v: Json, field: string, fail: Fail): TwinRule {
  const twin = v["twin"];
  if (typeof twin !== "string" || !NAME.test(twin)) return fail(`${field}.twin`, `the twin's action to answer with, got ${said(twin)}`);
  const allowed = twin === CARTESIAN_MOVE ? ["twin", "speed"] : twin === JOINT_MOVE ? ["twin", "joints", "speed"] : ["twin"];
  for (const k of Object.keys(v)) if (!allowed.includes(k)) fail(`${field}.${k.slice(0, 40)}`, `unknown field for ${twin} (known: ${allowed.join(", ")})`);
  const speed = v["speed"] !== undefined ? parseSpeed(v["speed"], field, fail) : undefined;
  if (twin === CARTESIAN_MOVE) return { kind: "cartesian", ...(speed !== undefined ? { speed } : {}) };
  if (twin !== JOINT_MOVE) return { kind: "direct", twin };
  if (typeof speed === "object") fail(`${field}.speed`, "a joint move takes a fixed speed fraction");
  const joints = v["joints"];
  if (joints === "home") return { kind: "joints", joints, ...(speed !== undefined ? { speed: speed as number } : {}) };
  if (!isObject(joints) || !Object.values(joints).every((x) => typeof x === "number" && Number.isFinite(x))) {
    return fail(`${field}.joints`, `"home" (the twin's home pose) or {JOINT: position} of every joint of the twin, got ${said(joints)}`);
  }
  return { kind: "joints", joints: joints as Record<string, number>, ...(speed !== undefined ? { speed: speed as number } : {}) };
}

function parsePropertyRule(v: unknown, field: string, fail: Fail): PropertyRule {
  if (v === "unsupported") return { kind: "unsupported" };
  if (!isObject(v)) return fail(field, `expected {"twin": PROPERTY} or "unsupported", got ${said(v)}`);
  for (const k of Object.keys(v)) if (k !== "twin") fail(`${field}.${k.slice(0, 40)}`, "unknown field (known: twin)");
  const twin = v["twin"];
  if (typeof twin !== "string" || !NAME.test(twin)) return fail(`${field}.twin`, `the twin's property to read, got ${said(twin)}`);
  return twin === POSE_PROPERTY ? { kind: "position" } : { kind: "direct", twin };
}

/** The metres of one device unit its x, y, z schemas say (`unit`, else integers are millimetres), or why not. */
function unitScale(props: Record<string, Json>): number | string {
  const units = new Set(AXES.map((a) => props[a]?.["unit"]));
  if (units.size > 1) return `x, y, z carry different units (${[...units].map(String).join(", ")})`;
  const unit = [...units][0];
  if (typeof unit === "string") return UNITS[unit.toLowerCase()] ?? `unit ${JSON.stringify(unit.slice(0, 20))} is not one of ${Object.keys(UNITS).join(", ")}`;
  if (AXES.every((a) => props[a]?.["type"] === "integer")) return UNITS["mm"] as number;
  return "x, y, z are numbers without a unit";
}

/** A property a client may write: not `readOnly` and a form offering `writeproperty`. */
const writable = (p: Json): boolean => p["readOnly"] !== true && JSON.stringify(p["forms"] ?? []).includes("writeproperty");

/**
 * The map inferred when `--as-map` is absent: an affordance the twin has by the same name maps to it; an
 * action whose input is exactly `{x, y, z}` is a Cartesian move and a property that is exactly `{x, y, z}`
 * and not writable (no `writeproperty` form) the twin's pose, in the unit their schemas name (`unit`: mm, cm, m) or, without one, millimetres when
 * all three are integers; the frame's offset is 0 and the orientation kept. Anything else is refused, every
 * such affordance named at once.
 */
export function defaultAsMap(file: string, device: TdDocument, twin: TdDocument): AsMap {
  const map: AsMap = { source: "the default map", frame: null, orientation: "keep", actions: new Map(), properties: new Map(), events: new Set(), twin: null };
  const refused: string[] = [];
  const scales = new Set<number>();
  const position = (props: Record<string, Json> | null, name: string): boolean => {
    if (!hasPosition(props) || Object.keys(props).length !== 3) return false;
    const s = unitScale(props);
    if (typeof s === "string") refused.push(`${name} (${s})`);
    else scales.add(s);
    return true;
  };
  for (const [name, a] of Object.entries(affordances(device, "actions"))) {
    // the twin's own action of the name: its input passed on as is (checked against the twin's schema too)
    if (affordances(twin, "actions")[name]) map.actions.set(name, { kind: "direct", twin: name });
    else if (position(objectSchema(a["input"]), `actions.${name}`)) map.actions.set(name, { kind: "cartesian" });
    else refused.push(`actions.${name}`);
  }
  for (const [name, p] of Object.entries(affordances(device, "properties"))) {
    if (affordances(twin, "properties")[name]) map.properties.set(name, { kind: "direct", twin: name });
    // a position the client can write (a home location) is a setting, not where the robot is
    else if (!writable(p) && position(objectSchema(p), `properties.${name}`)) map.properties.set(name, { kind: "position" });
    else refused.push(`properties.${name}`);
  }
  for (const name of Object.keys(affordances(device, "events"))) refused.push(`events.${name}`);
  if (scales.size > 1) refused.push(`the positions' units differ (${[...scales].join(", ")} m per unit)`);
  if (refused.length > 0) {
    throw new AsDeviceError(
      `${file}: no map can be inferred for ${refused.join(", ")}: write one (--as-map FILE; README "Serving a real device's TD"), naming the twin's affordance of each or "unsupported"`,
    );
  }
  if (scales.size === 1) map.frame = { scale: [...scales][0] as number, offset: [0, 0, 0] };
  return map;
}

/**
 * The map against both TDs: every affordance of the device has an entry and every entry names one; the
 * twin has each affordance named (the twin's gripper actions included: a twin without them is refused
 * naming the device's affordance); a Cartesian move's device input is `{x, y, z}` plus its speed field, a
 * joint move's takes none; a position property is `{x, y, z}`; a frame is given when positions are mapped.
 */
export function checkAsMap(map: AsMap, device: TdDocument, twin: TdDocument): void {
  const fail = (field: string, why: string): never => {
    throw new AsDeviceError(`${map.source}: ${field}: ${why}`);
  };
  const rules: Record<Kind, Map<string, unknown> | Set<string>> = { actions: map.actions, properties: map.properties, events: map.events };
  for (const kind of KINDS) {
    const names = Object.keys(affordances(device, kind));
    for (const n of names) if (!rules[kind].has(n)) fail(`${kind}.${n}`, `the device's ${ONE[kind]} has no entry (name the twin's, or say "unsupported": it then answers 501)`);
    for (const n of rules[kind].keys()) if (!names.includes(n)) fail(`${kind}.${n}`, `the device has no such ${ONE[kind]} (its ${kind}: ${names.join(", ") || "none"})`);
  }
  const twinHas = (kind: Kind, name: string, field: string): void => {
    const have = Object.keys(affordances(twin, kind));
    if (!have.includes(name)) fail(field, `the twin has no ${ONE[kind]} ${name} (its ${kind}: ${have.join(", ")})`);
  };
  let positions = false;
  for (const [name, rule] of map.actions) {
    const field = `actions.${name}`;
    const input = affordances(device, "actions")[name]?.["input"];
    if (rule.kind === "sequence") {
      if (input !== undefined) fail(field, "the device's action takes an input; a sequence of fixed steps takes none");
      rule.steps.forEach(({ rule: step }, k) => {
        const at = `${field}.sequence[${k}]`;
        twinHas("actions", step.kind === "cartesian" ? CARTESIAN_MOVE : step.kind === "joints" ? JOINT_MOVE : step.twin, at);
        if (step.kind === "joints") checkJoints(step.joints, twin, at, fail);
        if (step.kind === "cartesian") positions = true;
      });
      continue;
    }
    if (rule.kind === "direct") twinHas("actions", rule.twin, field);
    if (rule.kind === "joints") {
      twinHas("actions", JOINT_MOVE, field);
      if (input !== undefined) fail(field, `the device's action takes an input; a joint move to fixed joints takes none`);
      checkJoints(rule.joints, twin, field, fail);
    }
    if (rule.kind !== "cartesian") continue;
    twinHas("actions", CARTESIAN_MOVE, field);
    positions = true;
    const props = objectSchema(input);
    if (!hasPosition(props)) return fail(field, "a Cartesian move needs the device's input {x, y, z} (numbers or integers)");
    const required = (input as Json)["required"];
    if (!AXES.every((a) => Array.isArray(required) && required.includes(a))) fail(field, "the device's input must require x, y and z (a move to a partial position is not defined)");
    const speedField = typeof rule.speed === "object" ? rule.speed.field : null;
    if (speedField !== null && !isNumeric(props[speedField])) fail(`${field}.speed.field`, `the device's input has no number ${speedField}`);
    const extra = Object.keys(props).filter((k) => !(AXES as readonly string[]).includes(k) && k !== speedField);
    if (extra.length > 0) fail(field, `the device's input field(s) ${extra.join(", ")} have no counterpart (only x, y, z and a speed field map)`);
  }
  for (const [name, rule] of map.properties) {
    const field = `properties.${name}`;
    if (rule.kind === "direct") twinHas("properties", rule.twin, field);
    if (rule.kind !== "position") continue;
    twinHas("properties", POSE_PROPERTY, field);
    positions = true;
    const props = objectSchema(affordances(device, "properties")[name]);
    if (!hasPosition(props)) fail(field, "a position property needs the device's schema {x, y, z} (numbers or integers)");
  }
  if (positions && map.frame === null) fail("frame", `required: the device's positions are mapped ({"scale": metres per device unit, "offset": [x, y, z] m})`);
}

function checkJoints(joints: "home" | Record<string, number>, twin: TdDocument, field: string, fail: Fail): void {
  if (joints === "home") return;
  const names = Object.keys(objectSchema(affordances(twin, "properties")["getJointPosition"]) ?? {});
  const unknown = Object.keys(joints).filter((j) => !names.includes(j));
  const missing = names.filter((j) => !(j in joints));
  if (unknown.length > 0 || missing.length > 0) {
    fail(`${field}.joints`, `every joint of the twin exactly once (unknown: ${unknown.join(", ") || "none"}; missing: ${missing.join(", ") || "none"})`);
  }
}
