/**
 * `--as DEVICE=real-td.json`: the twin served a second time, as the physical device a mashup already talks
 * to. Its TD is the device's own (titles, affordance names, input and output schemas with their integer
 * types, ranges and units) with our forms (HTTP only, at `<url>/DEVICE/`), our security and an id of its
 * own; the map (`as-map.ts`) says which affordance of the twin answers each of its affordances:
 *
 * - inputs are checked against the DEVICE's schema by the router (400 naming the field), converted
 *   (position * scale + offset, the orientation kept or fixed, a speed field to the twin's fraction) and
 *   handed to the twin's own action handler: one code path for moving (busy 409, stop, relay, monitor);
 * - a target the twin refuses (outside its workspace, unreachable, colliding) answers 422: the device's
 *   declared error response when its TD has one (`additionalResponses` with a `schema`), else problem
 *   details with the twin's reasons; a move that ends otherwise than reached (stopped, collision, a failed
 *   relay) answers 409 `E_NOT_REACHED`;
 * - a move answers when the twin's motion has ended (the device may answer at once: a mashup that awaits
 *   the action and then waits still works, one that does not await may meet 409 `E_BUSY`);
 * - a position property reads the twin's pose back in the device's units (integers rounded);
 * - an affordance the map calls "unsupported" stays in the TD and answers 501.
 */
import { MIN_SPEED, PROBLEM_JSON, securityFor, TD_CONTEXT_V10, type ThingDescription, withAbsoluteForms, type Xyz } from "@robwot/core";
import type { ActionHandler, Affordances } from "./affordance-routes.js";
import { ActionStatusStore } from "./action-status.js";
import {
  AS_MAP_LIMITS,
  AS_TD_LIMITS,
  AsDeviceError,
  CARTESIAN_MOVE,
  checkAsMap,
  checkDeviceTd,
  defaultAsMap,
  JOINT_MOVE,
  parseAsMap,
  readJsonFile,
  type ActionRule,
  type AsMap,
  type SequenceStep,
  type TwinRule,
  type Json,
  type PropertyRule,
} from "./as-map.js";
import type { AuthConfig } from "./auth.js";
import { ServientError, servientError, toServientError } from "./errors.js";
import type { ServedThing } from "./http-middleware.js";
import { compileInput, validateInput } from "./input-validation.js";
import type { SseSource } from "./sse.js";
import type { TdDocument } from "./twin-folder.js";
import type { Twin } from "./twin.js";

export { AsDeviceError } from "./as-map.js";

/** `--as NAME=TD [--as-map MAP]`. */
export interface AsDeviceSpec {
  /** the URL path segment the device is served at */
  name: string;
  /** the device's TD file */
  td: string;
  /** the map file; absent: `defaultAsMap` */
  map?: string;
}

/** A device checked at start: its TD and the map, both against the twin that answers as it. */
export interface PreparedDevice {
  name: string;
  /** the twin (its URL path segment) answering as the device */
  twin: string;
  file: string;
  td: TdDocument;
  map: AsMap;
}

const SEGMENT = /^[A-Za-z0-9_-]{1,64}$/;
const AXES = ["x", "y", "z"] as const;
const JSON_TYPE = "application/json";

/** Reads and checks the device's TD and its map against the TD of the twin that answers as it (the map's
 *  `twin`, else the one twin served), before anything starts. `twins`: the served twins' TDs by path. */
export function prepareDevice(spec: AsDeviceSpec, twins: ReadonlyMap<string, TdDocument>, taken: ReadonlySet<string>): PreparedDevice {
  if (!SEGMENT.test(spec.name)) throw new AsDeviceError(`--as ${spec.name.slice(0, 70)}: the device's name is its URL path segment: 1-64 of A-Z a-z 0-9 _ -`);
  if (taken.has(spec.name)) throw new AsDeviceError(`--as ${spec.name}: the URL path /${spec.name} is taken (a twin's or the servient's own); choose another name`);
  const td = checkDeviceTd(spec.td, readJsonFile(spec.td, "device TD", AS_TD_LIMITS));
  for (const [name, a] of Object.entries((td.actions ?? {}) as Record<string, Json>)) {
    if (a["input"] === undefined) continue;
    try {
      compileInput(a["input"] as object);
    } catch (err) {
      throw new AsDeviceError(`${spec.td}: actions.${name}.input: not a usable JSON schema: ${err instanceof Error ? err.message.slice(0, 200) : String(err)}`);
    }
  }
  const parsed = spec.map ? parseAsMap(spec.map, readJsonFile(spec.map, "map", AS_MAP_LIMITS)) : null;
  const slug = parsed?.twin ?? (twins.size === 1 ? [...twins.keys()][0]! : null);
  if (slug === null) {
    throw new AsDeviceError(`--as ${spec.name}: ${twins.size} twins are served: its --as-map must name the one that answers as the device ("twin": one of ${[...twins.keys()].join(", ")})`);
  }
  const twinTd = twins.get(slug);
  if (twinTd === undefined) throw new AsDeviceError(`${spec.map}: twin: no twin is served at /${slug} (the twins: ${[...twins.keys()].join(", ")})`);
  const map = parsed ?? defaultAsMap(spec.td, td, twinTd);
  checkAsMap(map, td, twinTd);
  return { name: spec.name, twin: slug, file: spec.td, td, map };
}

/** What serving the device needs of the servient and of the twin behind it. */
export interface DeviceEnv {
  url: string;
  auth: AuthConfig | undefined;
  twin: Twin;
  /** the twin as the router serves it: its handlers, readers, schemas and streams */
  behind: ServedThing;
}

/** The device as the router serves it, at `/<name>`, answered by the twin behind it. */
export function exposeDevice(p: PreparedDevice, env: DeviceEnv): ServedThing {
  const actions = new Map<string, ActionHandler>();
  for (const [name, rule] of p.map.actions) actions.set(name, actionHandler(p, env, name, rule));
  const properties = new Map<string, () => unknown>();
  for (const [name, rule] of p.map.properties) properties.set(name, propertyReader(p, env, name, rule));
  let cached: TdDocument | null = null;
  const td = (): TdDocument => (cached ??= deviceTd(p, env));
  return {
    slug: p.name,
    // the twin's files (URDF, meshes, workspace) are the device's too
    dir: env.behind.dir,
    urdfName: env.behind.urdfName,
    td,
    actionInput: (name) => {
      const a = (p.td.actions as Record<string, Json> | undefined)?.[name];
      return a ? ((a["input"] as object | undefined) ?? undefined) : null;
    },
    observe: (kind, name) => (kind === "properties" ? propertySource(p, env, name, properties.get(name)) : null),
    affordances: { properties, actions } satisfies Affordances,
    statuses: new ActionStatusStore(),
  };
}

/** An affordance the map leaves to the real device: 501 problem details. */
const unsupported = (p: PreparedDevice, kind: string, name: string): ServientError =>
  servientError("E_NOT_IMPLEMENTED", `${p.name}: the ${kind} ${name} is not served by the twin behind this Thing (its map says "unsupported")`, { device: p.name, [kind]: name });

/** The device's coordinates as the twin's metres (frame: scale, then offset). */
function toTwin(p: PreparedDevice, i: Json): Xyz {
  const f = p.map.frame ?? { scale: 1, offset: [0, 0, 0] };
  const [x, y, z] = AXES.map((a, k) => (i[a] as number) * f.scale + (f.offset[k] ?? 0)) as [number, number, number];
  return { x, y, z };
}

/** The twin's position in the device's units, each coordinate the device's schema says is an integer rounded. */
function toDevice(p: PreparedDevice, pos: Xyz, schema: unknown): Json {
  const f = p.map.frame ?? { scale: 1, offset: [0, 0, 0] };
  const props = ((schema as Json | undefined)?.["properties"] ?? {}) as Record<string, Json>;
  const out: Json = {};
  AXES.forEach((a, k) => {
    const v = (pos[a] - (f.offset[k] ?? 0)) / f.scale;
    out[a] = props[a]?.["type"] === "integer" ? Math.round(v) : v;
  });
  return out;
}

/** A sequence: its steps one after the other, each through the twin's own action handler (each a motion of
 *  its own: busy, stop and relay hold per step); the first that fails ends it, its error naming the step. */
function sequenceHandler(p: PreparedDevice, env: DeviceEnv, name: string, steps: SequenceStep[]): ActionHandler {
  const run = steps.map((s, k) => ({ handler: actionHandler(p, env, `${name}[${k}]`, s.rule), input: s.position ?? {} }));
  return async () => {
    for (const step of run) await step.handler(step.input);
    return undefined;
  };
}

function actionHandler(p: PreparedDevice, env: DeviceEnv, name: string, rule: ActionRule): ActionHandler {
  if (rule.kind === "unsupported") {
    return () => Promise.reject(unsupported(p, "action", name));
  }
  if (rule.kind === "sequence") return sequenceHandler(p, env, name, rule.steps);
  const twinName = rule.kind === "cartesian" ? CARTESIAN_MOVE : rule.kind === "joints" ? JOINT_MOVE : rule.twin;
  const handler = env.behind.affordances.actions.get(twinName);
  // the twin's TD names it but this servient has no handler for it (a folder of a newer version)
  if (!handler) throw new AsDeviceError(`${p.map.source}: actions.${name}: the twin does not serve the action ${twinName}`);
  const action = ((p.td.actions ?? {}) as Record<string, Json>)[name] ?? {};
  const shape = declaredError(p.td, action);
  return async (input) => {
    const twinInput = rule.kind === "cartesian" ? cartesianInput(p, env, rule, input as Json) : rule.kind === "joints" ? jointInput(env, rule) : (input ?? {});
    // the twin's own schema (its workspace bounds, joint limits): the device's input can be valid and the
    // target still outside what the twin can reach
    try {
      validateInput(env.behind.actionInput(twinName) ?? undefined, twinInput, twinName);
    } catch (err) {
      const e = toServientError(err);
      if (rule.kind === "direct") throw e;
      throw refused(shape, servientError("E_REJECTED", `${name}: the twin cannot take ${JSON.stringify(twinInput)}: ${e.message}`, { reasons: [e.message], twin: twinInput }));
    }
    let result: unknown;
    try {
      result = await handler(twinInput);
    } catch (err) {
      const e = toServientError(err);
      throw e.status === 422 ? refused(shape, e) : e;
    }
    return rule.kind === "direct" ? directAnswer(name, twinName, action, result) : moveAnswer(p, name, action, result as MoveResult);
  };
}

/** The twin's answer to a device action mapped by name: its output when the device declares one (none: 204);
 *  an action that ended `stopped` or in a `collision` (a gripper stopped before it closed) is a 409. */
function directAnswer(name: string, twinName: string, action: Json, result: unknown): unknown {
  const status = (result as Json | null | undefined)?.["status"];
  if (status === "stopped" || status === "collision") throw servientError("E_NOT_REACHED", `${name}: the twin's ${twinName} ended ${status}`, { status, twin: result });
  return action["output"] === undefined ? undefined : result;
}

function cartesianInput(p: PreparedDevice, env: DeviceEnv, rule: Extract<TwinRule, { kind: "cartesian" }>, i: Json): Json {
  const target: Json = { ...toTwin(p, i) };
  const o = p.map.orientation;
  if (o === "keep") target["orientation"] = env.twin.realPose().orientation;
  else if (o !== "free") target["orientation"] = o;
  if (typeof rule.speed === "number") target["speed"] = rule.speed;
  else if (rule.speed && typeof i[rule.speed.field] === "number") {
    target["speed"] = Math.min(1, Math.max(MIN_SPEED, (i[rule.speed.field] as number) / rule.speed.max));
  }
  return target;
}

function jointInput(env: DeviceEnv, rule: Extract<TwinRule, { kind: "joints" }>): Json {
  const names = Object.keys(((env.twin.folder.td.properties?.["getJointPosition"] as Json | undefined)?.["properties"] ?? {}) as object);
  const home = env.twin.folder.manifest.robot.home?.joints ?? {};
  const joints = rule.joints === "home" ? Object.fromEntries(names.map((j) => [j, home[j] ?? 0])) : rule.joints;
  return { joints, ...(rule.speed !== undefined ? { speed: rule.speed } : {}) };
}

interface MoveResult {
  status: string;
  position: Xyz;
  relay?: { ok: boolean; error?: string };
}

/** A move's answer to the device's client: its declared output (a position, in its units) or none (204);
 *  a move that did not reach its target (stopped, collision, relay failed) is a 409. */
function moveAnswer(p: PreparedDevice, name: string, action: Json, r: MoveResult): unknown {
  const where = toDevice(p, r.position, action["output"]);
  if (r.status !== "reached") throw servientError("E_NOT_REACHED", `${name}: the twin's move ended ${r.status}`, { status: r.status, position: where });
  if (r.relay && !r.relay.ok) throw servientError("E_NOT_REACHED", `${name}: the physical robot did not take the move: ${r.relay.error ?? "relay failed"}`, { status: r.status, relay: r.relay });
  const out = action["output"] as Json | undefined;
  const props = out?.["properties"] as Json | undefined;
  return props && AXES.every((a) => a in props) ? where : undefined;
}

function propertyReader(p: PreparedDevice, env: DeviceEnv, name: string, rule: PropertyRule): () => unknown {
  if (rule.kind === "unsupported") {
    return () => {
      throw unsupported(p, "property", name);
    };
  }
  if (rule.kind === "direct") {
    const read = env.behind.affordances.properties.get(rule.twin);
    if (!read) throw new AsDeviceError(`${p.map.source}: properties.${name}: the twin does not serve the property ${rule.twin}`);
    return read;
  }
  const schema = ((p.td.properties ?? {}) as Record<string, Json>)[name];
  return () => toDevice(p, env.twin.realPose().position, schema);
}

/** The SSE source of a mapped property: the twin's own stream, or the pose's changes in device units. */
function propertySource(p: PreparedDevice, env: DeviceEnv, name: string, read: (() => unknown) | undefined): SseSource | null {
  const rule = p.map.properties.get(name);
  if (!rule || !read || rule.kind === "unsupported") return null;
  if (rule.kind === "direct") return env.behind.observe("properties", rule.twin);
  return {
    current: read,
    subscribe: (send) => {
      const listener = (): void => send(read());
      env.twin.on("joints", listener);
      return () => void env.twin.off("joints", listener);
    },
  };
}

/** The error response the device's action declares (`additionalResponses`, `success: false`, a `schema` of
 *  its `schemaDefinitions` that is an object), or null. */
interface ErrorShape {
  response: Json;
  contentType: string;
  properties: Record<string, Json>;
}

function declaredError(td: TdDocument, action: Json): ErrorShape | null {
  const defs = ((td as Json)["schemaDefinitions"] ?? {}) as Record<string, Json>;
  for (const f of (Array.isArray(action["forms"]) ? action["forms"] : []) as Json[]) {
    const responses = Array.isArray(f["additionalResponses"]) ? (f["additionalResponses"] as Json[]) : [];
    for (const r of responses) {
      const schema = typeof r["schema"] === "string" && Object.hasOwn(defs, r["schema"]) ? defs[r["schema"]] : undefined;
      if (r["success"] !== false || !schema || schema["type"] !== "object" || typeof schema["properties"] !== "object") continue;
      return { response: r, contentType: typeof r["contentType"] === "string" ? r["contentType"] : JSON_TYPE, properties: schema["properties"] as Record<string, Json> };
    }
  }
  return null;
}

/** The twin's refusal in the device's declared error shape: its message, code, status and reasons where
 *  the shape has a field of such a name and type; problem details when it declares none. */
function refused(shape: ErrorShape | null, e: ServientError): ServientError {
  if (!shape) return e;
  const body: Json = {};
  for (const [field, s] of Object.entries(shape.properties)) {
    const f = field.toLowerCase();
    const type = s["type"];
    if (type === "string" && ["message", "detail", "description", "error", "reason", "title", "msg"].includes(f)) body[field] = e.message;
    else if (type === "string" && f === "code") body[field] = e.code;
    else if ((type === "integer" || type === "number") && ["status", "statuscode", "code"].includes(f)) body[field] = e.status;
    else if (type === "array" && f === "reasons") body[field] = (e.details["reasons"] as unknown[] | undefined) ?? [e.message];
  }
  const out = new ServientError(e.status, e.code, e.message, e.details);
  out.shaped = { contentType: shape.contentType, body };
  return out;
}

/** The device's TD as served: its own with our forms, base, security, an id of its own, its unsupported
 *  events left out, and a link to the twin behind it. */
function deviceTd(p: PreparedDevice, env: DeviceEnv): TdDocument {
  const td = structuredClone(p.td) as Json;
  for (const k of ["forms", "base", "security", "securityDefinitions", "links", "events"]) delete td[k];
  const twinTd = env.behind.td();
  td["@context"] ??= TD_CONTEXT_V10;
  td["id"] = `${String(twinTd["id"] ?? `urn:robwot:${env.behind.slug}`)}:as:${p.name}`;
  td["base"] = `${env.url}/${p.name}/`;
  td["links"] = [{ rel: "robwot:twin", href: `${env.url}/${env.behind.slug}`, type: "application/td+json" }];
  const problem = { success: false, contentType: PROBLEM_JSON };
  for (const [name, a] of Object.entries((td["properties"] ?? {}) as Record<string, Json>)) {
    const observable = a["observable"] === true || JSON.stringify(p.td.properties?.[name]?.forms ?? []).includes("observeproperty");
    delete a["uriVariables"];
    const rule = p.map.properties.get(name);
    a["forms"] = [
      { href: `properties/${name}`, contentType: JSON_TYPE, op: ["readproperty"], "htv:methodName": "GET", additionalResponses: [problem] },
      ...(observable && rule?.kind !== "unsupported" ? [{ href: `properties/${name}/sse`, contentType: JSON_TYPE, op: ["observeproperty", "unobserveproperty"], subprotocol: "sse" }] : []),
    ];
  }
  for (const [name, a] of Object.entries((td["actions"] ?? {}) as Record<string, Json>)) {
    const shape = declaredError(p.td, ((p.td.actions ?? {}) as Record<string, Json>)[name] ?? {});
    delete a["uriVariables"];
    // a plain POST answers once the twin's move has ended
    a["synchronous"] = true;
    a["forms"] = [{ href: `actions/${name}`, contentType: JSON_TYPE, op: ["invokeaction"], "htv:methodName": "POST", additionalResponses: [shape ? shape.response : problem] }];
  }
  const secured = securityFor(withAbsoluteForms(td, String(td["base"])) as unknown as ThingDescription, env.auth ? { scheme: env.auth.scheme } : null);
  return secured as unknown as TdDocument;
}
