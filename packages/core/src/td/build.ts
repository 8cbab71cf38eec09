/**
 * Thing Description builder (Contract 3). Forms use node-wot 0.9.2 HttpServer's URL layout relative to
 * `base` = `<baseUrl><slug>/`: `properties/<name>` (GET, readproperty), `properties/<name>/observable`
 * (longpoll observeproperty), `actions/<name>` (POST, invokeaction), `events/<name>` (longpoll
 * subscribeevent), and `properties` (readallproperties) at the Thing level.
 */
import type { Coupling } from "../backend-contract.js";
import { transformBounds, type SimilarityTransform } from "../calibration.js";
import type { TdCoupling } from "../couplings.js";
import { ThingDescriptionError } from "../errors.js";
import { TWIN_FILES } from "../twin-layout.js";
import type { Bounds, GripperDecl, JointSpec, RobotModelLike, WorkspaceSummary } from "../types.js";
import { ACTION_STATUS_SCHEMA, actionStatusSchema, ASYNC_ACTIONS, asyncActionForms, asyncActionVariables } from "./async-actions.js";
import { actionAffordances, eventAffordances, gripperActions, gripperProperty, propertyAffordances } from "./affordances.js";
import { canonicalJson, fnv1a64, MAX_SLUG_LENGTH, thingSlug } from "./hash.js";
import { PROBLEM_JSON, PROBLEM_SCHEMA } from "./problem.js";
import { closeSchema, moveResultSchema } from "./schemas.js";
import type { ActionAffordance, DataSchema, EventAffordance, Form, Link, PropertyAffordance, ThingDescription } from "./types.js";

export const TD_CONTEXT_V11 = "https://www.w3.org/2022/wot/td/v1.1";
/**
 * TD 1.1 allows `[v1, v1.1, ...]` for backward compatibility; node-wot 0.9.2 consumers validate TDs
 * against the TD 1.0 schema, which wants the v1 context first, so every TD we write starts with both.
 */
export const TD_CONTEXT_V10 = "https://www.w3.org/2019/wot/td/v1";
export const ROBWOT_NS = "https://robwot.dev/ns#";
/** The Thing Model every twin's TD links with `rel: "type"` (`thing-model.ts`): the twin layout's `thingModel` file. */
export const THING_MODEL_FILE = TWIN_FILES.thingModel;
export const THING_MODEL_TYPE = "application/tm+json";
/** Link relation of the servient's `/live` WebSocket stream (its own protocol, README Contract 4). */
export const LIVE_REL = "robwot:live";
/** Link relation of reachability.csv, the reachability map (README "Reachability map"). */
export const REACHABILITY_REL = "robwot:reachability";
export const DEFAULT_BASE_URL = "http://localhost:8080/";
/**
 * The W3C WoT Profiles every twin conforms to (TD `profile`; the Profile requires the TD 1.1 context):
 * HTTP Basic (properties, actions, ActionStatus, errors) and HTTP SSE (the `subprotocol: "sse"` forms).
 */
export const WOT_PROFILES = ["https://www.w3.org/2022/wot/profile/http-basic/v1", "https://www.w3.org/2022/wot/profile/http-sse/v1"] as const;
const JSON_TYPE = "application/json";

export interface BuildThingDescriptionOptions {
  model: RobotModelLike;
  /** workspace.json; its bounds give the Cartesian minimum/maximum. null: no Cartesian bounds. */
  summary: WorkspaceSummary | null;
  /** Absolute http(s) URL of the servient, default `http://localhost:8080/`. */
  baseUrl?: string;
  /** URL path segment of the Thing, default `thingSlug(title)` (node-wot's devFriendlyUri path). */
  slug?: string;
  /** Default `urn:robwot:<slug>:<FNV-1a-64 of robot model + sceneId>`. */
  id?: string;
  /** Identifies the scene (e.g. a hash of scene.json) so the same robot in another scene gets another id. */
  sceneId?: string;
  /** Default: the robot name. */
  title?: string;
  description?: string;
  /** When given, Cartesian bounds are mapped into the real frame (axis-aligned box of the 8 corners). */
  calibration?: SimilarityTransform | null;
  /** Live WebSocket endpoint (Contract 4), linked with rel LIVE_REL; default ws(s)://<host of baseUrl>/live; null: no link. */
  liveUrl?: string | null;
  /** The twin folder holds robot.srdf (linked with rel "srdf"). */
  srdf?: boolean;
  /** A tool mounted on `flange` (`--tcp`, `--tool-mesh`): the model's end effector is its TCP link. */
  tool?: { flange: string; tcp: readonly number[]; mesh?: string; shape?: Record<string, unknown> };
  /** `--gripper`: the property `gripper` and the actions `gripOpen`, `gripClose` */
  gripper?: GripperDecl;
}

function controllableJoints(model: RobotModelLike): JointSpec[] {
  const byName = new Map(model.joints.map((j) => [j.name, j]));
  if (model.controllable.length === 0) {
    throw new ThingDescriptionError(`robot '${model.name}' has no controllable joint`, { field: "model.controllable" });
  }
  return model.controllable.map((name) => {
    const j = byName.get(name);
    if (!j) {
      throw new ThingDescriptionError(`controllable joint '${name}' is not in the model's joints`, {
        field: "model.controllable",
        joint: name,
        available: [...byName.keys()],
      });
    }
    if (!Number.isFinite(j.lower) || !Number.isFinite(j.upper) || j.lower > j.upper) {
      throw new ThingDescriptionError(`joint '${name}' has invalid limits [${j.lower}, ${j.upper}]`, {
        field: "model.joints",
        joint: name,
        lower: j.lower,
        upper: j.upper,
      });
    }
    return j;
  });
}

function checkBounds(b: Bounds): Bounds {
  for (let i = 0; i < 3; i++) {
    const lo = b.min[i];
    const hi = b.max[i];
    if (lo === undefined || hi === undefined || !Number.isFinite(lo) || !Number.isFinite(hi) || lo > hi) {
      throw new ThingDescriptionError(`workspace bounds are invalid on axis ${i}: [${lo}, ${hi}]`, { field: "summary.reachBounds", axis: i, min: lo, max: hi });
    }
  }
  return b;
}

/**
 * The box that bounds Cartesian targets in the TD: every position the end link can reach
 * (`reachBounds`, from the kinematic chain) — the sampled points' `bounds` fall short of the true
 * extremes, and a schema bounded by them refused reachable targets. Twin folders written before
 * `reachBounds` existed fall back to `bounds`.
 */
export function targetBounds(summary: Pick<WorkspaceSummary, "bounds" | "reachBounds">): Bounds {
  const b = summary.reachBounds ?? summary.bounds;
  if (b.min === null || b.max === null) {
    throw new ThingDescriptionError("the workspace has no collision-free sample: there are no Cartesian bounds", { field: "summary.bounds" });
  }
  return { min: b.min, max: b.max };
}

function normaliseBaseUrl(baseUrl: string): URL {
  let url: URL;
  try {
    url = new URL(baseUrl);
  } catch {
    throw new ThingDescriptionError(`baseUrl '${baseUrl}' is not an absolute URL`, { field: "baseUrl", value: baseUrl });
  }
  if (url.protocol !== "http:" && url.protocol !== "https:") {
    throw new ThingDescriptionError(`baseUrl '${baseUrl}' must be http or https`, { field: "baseUrl", value: baseUrl });
  }
  if (!url.pathname.endsWith("/")) url.pathname += "/";
  return url;
}

/** The couplings given or derived at load (not the URDF's `<mimic>` tags). */
function addedCouplings(model: RobotModelLike): Coupling[] {
  return (model.couplings ?? []).filter((c) => c.source !== "mimic");
}

/** A coupling as the TD states it: the follower's value is `sum(factor * joint) + offset` (rad or m). */
function tdCoupling(c: Coupling): TdCoupling {
  return { follower: c.follower, terms: c.terms.map((t) => ({ joint: t.joint, factor: t.factor })), offset: c.offset, expression: c.expression, source: c.source };
}

/** Stable Thing id: same robot model + same scene id gives the same urn. */
export function thingId(model: RobotModelLike, slug: string, sceneId?: string): string {
  const robot = {
    name: model.name,
    eeLink: model.eeLink,
    controllable: model.controllable,
    joints: model.joints.map((j) => ({ name: j.name, type: j.type, lower: j.lower, upper: j.upper, velocity: j.velocity, effort: j.effort, mimic: j.mimic })),
    basePosition: model.basePosition,
    baseOrientation: model.baseOrientation,
    // rules beyond the URDF's own mimic tags make another robot (absent: the ids of earlier twins hold)
    ...(addedCouplings(model).length > 0 ? { couplings: addedCouplings(model).map((c) => c.expression) } : {}),
  };
  return `urn:robwot:${slug}:${fnv1a64(canonicalJson({ robot, scene: sceneId ?? null }))}`;
}

/**
 * The body of every error answer (400 bad input, 401 unauthorised, 403/421 refused, 404, 409 busy or
 * name taken, 415, 422 rejected by validation, 503 backend down): RFC 7807 problem details
 * (`problem.ts`), declared on every form so that a consumer can tell an error body from a result.
 */
const ERROR_SCHEMA: DataSchema = PROBLEM_SCHEMA;
/**
 * Error answers of an action, one per HTTP status (TD 1.1 Form `additionalResponses`: each one is told
 * apart from the others by a protocol-specific response code, here the HTTP binding's
 * `htv:statusCodeValue`): 400 bad input, 404 unknown obstacle, 409 busy or name taken, 413 body too
 * large, 415 not JSON, 422 rejected by validation, 503 backend down, 504 backend timeout.
 */
export const ACTION_ERROR_STATUSES = [400, 404, 409, 413, 415, 422, 503, 504] as const;
const ERROR_RESPONSES = ACTION_ERROR_STATUSES.map((status) => ({ success: false, contentType: PROBLEM_JSON, schema: "error", "htv:statusCodeValue": status }));
/** A property read answers from the twin's memory: an error (auth, host) has no status of its own. */
const READ_ERROR_RESPONSES = [{ success: false, contentType: PROBLEM_JSON, schema: "error" }];

function propertyForms(name: string, observable: boolean): Form[] {
  const forms: Form[] = [{ href: `properties/${name}`, contentType: JSON_TYPE, op: ["readproperty"], "htv:methodName": "GET", additionalResponses: READ_ERROR_RESPONSES }];
  if (observable) {
    forms.push({ href: `properties/${name}/observable`, contentType: JSON_TYPE, op: ["observeproperty", "unobserveproperty"], subprotocol: "longpoll" });
    // the WoT Profile's Server-Sent Events: one stream of every new value (data: JSON)
    forms.push({ href: `properties/${name}/sse`, contentType: JSON_TYPE, op: ["observeproperty", "unobserveproperty"], subprotocol: "sse" });
  }
  return forms;
}

export function buildThingDescription(options: BuildThingDescriptionOptions): ThingDescription {
  const { model, summary } = options;
  const joints = controllableJoints(model);
  const title = options.title ?? model.name;
  const slug = checkedSlug(title, options.slug);
  const base = normaliseBaseUrl(options.baseUrl ?? DEFAULT_BASE_URL);
  let live: string | null = null;
  if (options.liveUrl !== null) {
    live = options.liveUrl ?? `${base.protocol === "https:" ? "wss:" : "ws:"}//${base.host}/live`;
  }
  let bounds = summary ? checkBounds(targetBounds(summary)) : null;
  if (bounds && options.calibration) bounds = transformBounds(bounds, options.calibration);

  const td: ThingDescription = {
    "@context": [TD_CONTEXT_V10, TD_CONTEXT_V11, { "@language": "en", robwot: ROBWOT_NS }],
    "@type": ["Thing", "robwot:RobotArmTwin"],
    id: options.id ?? thingId(model, slug, options.sceneId),
    profile: [...WOT_PROFILES],
    title,
    description: options.description ?? defaultDescription(model, joints, summary, options.tool),
    base: `${base.href}${slug}/`,
    securityDefinitions: { nosec_sc: { scheme: "nosec" } },
    // the ActionStatus of the asynchronous moves (`async-actions.ts`); their output is the move result
    schemaDefinitions: { error: ERROR_SCHEMA, [ACTION_STATUS_SCHEMA]: actionStatusSchema(moveResultSchema(joints), ERROR_SCHEMA) },
    security: "nosec_sc",
    properties: propertiesWithForms(joints, options.gripper !== undefined),
    actions: actionsWithForms(joints, bounds, options.gripper !== undefined),
    events: eventsWithForms(joints),
    links: twinLinks(options.srdf === true, live),
    forms: [{ href: "properties", contentType: JSON_TYPE, op: ["readallproperties", "readmultipleproperties"] }],
    "robwot:robot": model.name,
    "robwot:eeLink": model.eeLink,
    "robwot:controllableJoints": joints.map((j) => j.name),
    ...(model.clearance !== undefined ? { "robwot:clearance": model.clearance } : {}),
    ...(options.tool ? { "robwot:tool": toolTerm(options.tool) } : {}),
    ...(options.gripper ? { "robwot:gripper": { ...options.gripper, unit: { time: "s", capture: "m" } } } : {}),
    ...((model.couplings ?? []).length > 0 ? { "robwot:couplings": (model.couplings ?? []).map(tdCoupling) } : {}),
  };
  if (summary) {
    td["robwot:workspace"] = {
      samples: summary.samples,
      collisionFree: summary.collisionFree,
      method: summary.method,
      alpha: summary.alpha,
      volume: summary.volume,
      seed: summary.seed,
      bounds: summary.bounds,
    };
  }
  return withAbsoluteForms(td);
}

/** The Thing's URL path segment: `slug`, or the one `title` gives; a plain segment the servient can serve. */
function checkedSlug(title: string, slugIn: string | undefined): string {
  if (title.trim().length === 0) throw new ThingDescriptionError("title is empty", { field: "title" });
  const slug = slugIn ?? thingSlug(title);
  if (slug.length > MAX_SLUG_LENGTH) {
    throw new ThingDescriptionError(`title "${title.slice(0, 40)}..." gives a URL path segment of ${slug.length} characters; at most ${MAX_SLUG_LENGTH} can be served`, { field: "title", value: title });
  }
  if (!/^[A-Za-z0-9._~-]+$/.test(slug)) {
    throw new ThingDescriptionError(`slug '${slug}' is not a plain URL path segment`, { field: "slug", value: slug });
  }
  return slug;
}

function propertiesWithForms(joints: JointSpec[], gripper: boolean): Record<string, PropertyAffordance> {
  const properties: Record<string, PropertyAffordance> = {};
  for (const [name, p] of Object.entries({ ...propertyAffordances(joints), ...(gripper ? { gripper: gripperProperty() } : {}) })) {
    properties[name] = { ...p, forms: propertyForms(name, p.observable === true) };
  }
  return properties;
}

function actionsWithForms(joints: JointSpec[], bounds: Bounds | null, gripper: boolean): Record<string, ActionAffordance> {
  const actions: Record<string, ActionAffordance> = {};
  for (const [name, a] of Object.entries({ ...actionAffordances(joints, bounds), ...(gripper ? gripperActions() : {}) })) {
    const sync: Form = { href: `actions/${name}`, contentType: JSON_TYPE, op: ["invokeaction"], "htv:methodName": "POST", additionalResponses: ERROR_RESPONSES };
    const isAsync = ASYNC_ACTIONS.includes(name);
    // inputs are closed: the servient refuses a property the schema does not name, and the TD says so
    // the WoT Profile wants `synchronous` on every action: a plain POST answers once the action has ended
    // (the moves' `Prefer: respond-async` form is a capability beyond the Profile, README "Asynchronous moves")
    actions[name] = {
      ...a,
      synchronous: true,
      ...(a.input ? { input: closeSchema(a.input) as DataSchema } : {}),
      ...(isAsync ? { uriVariables: asyncActionVariables() } : {}),
      forms: isAsync ? [sync, ...asyncActionForms(name, sync, ERROR_RESPONSES)] : [sync],
    };
  }
  return actions;
}

function eventsWithForms(joints: JointSpec[]): Record<string, EventAffordance> {
  const events: Record<string, EventAffordance> = {};
  for (const [name, e] of Object.entries(eventAffordances(joints))) {
    const forms: Form[] = [
      { href: `events/${name}`, contentType: JSON_TYPE, op: ["subscribeevent", "unsubscribeevent"], subprotocol: "longpoll" },
      { href: `events/${name}/sse`, contentType: JSON_TYPE, op: ["subscribeevent", "unsubscribeevent"], subprotocol: "sse" },
    ];
    events[name] = { ...e, forms };
  }
  return events;
}

/** The twin folder's files, the Thing Model and the servient's `/live` stream (when there is one). */
function twinLinks(srdf: boolean, live: string | null): Link[] {
  return [
    { rel: "model", href: TWIN_FILES.urdf, type: "application/urdf+xml" },
    { rel: "workspace-pointcloud", href: TWIN_FILES.pointCloud, type: "text/csv" },
    { rel: "workspace", href: TWIN_FILES.surface, type: "model/stl" },
    { rel: "workspace-summary", href: TWIN_FILES.summary, type: JSON_TYPE },
    { rel: REACHABILITY_REL, href: TWIN_FILES.reachability, type: "text/csv" },
    { rel: "scene", href: TWIN_FILES.scene, type: JSON_TYPE },
    ...(srdf ? [{ rel: "srdf", href: TWIN_FILES.srdf, type: "application/xml" }] : []),
    { rel: "type", href: TWIN_FILES.thingModel, type: THING_MODEL_TYPE },
    // the servient's own WebSocket stream (all twins' joints, status, collisions, scene edits; protocol in
    // the README, Contract 4): a link, not a form, since no standard operation speaks it
    ...(live ? [{ rel: LIVE_REL, href: live, type: JSON_TYPE }] : []),
  ];
}

/** The TCP (m, rad: fixed-axis roll, pitch, yaw as a URDF <origin>) from the flange the tool is mounted on. */
function toolTerm(tool: NonNullable<BuildThingDescriptionOptions["tool"]>): Record<string, unknown> {
  return {
    flange: tool.flange,
    tcp: { xyz: tool.tcp.slice(0, 3), rpy: tool.tcp.slice(3, 6), unit: ["m", "rad"] },
    ...(tool.mesh !== undefined ? { mesh: tool.mesh } : {}),
    ...(tool.shape !== undefined ? { shape: tool.shape } : {}),
  };
}

/**
 * Every form's `href` resolved against `base`: TD 1.1 lets consumers resolve relative hrefs, but some
 * (wotpy 0.18) do not. With `newBase`, forms under the old base move to the new one and `base` becomes
 * it (the servient, for the address it serves on).
 */
export function withAbsoluteForms<T extends object>(td: T, newBase?: string): T {
  const doc = td as Record<string, unknown>;
  const base = typeof doc.base === "string" ? doc.base : undefined;
  if (base === undefined) return td;
  const target = newBase ?? base;
  const fix = (forms: unknown): void => {
    if (!Array.isArray(forms)) return;
    for (const f of forms as { href?: unknown }[]) {
      if (typeof f.href !== "string") continue;
      // a form under the old base moves with it to the new one
      const rel = f.href.startsWith(base) ? f.href.slice(base.length) : f.href;
      // a URI template's `{var}` is kept as written (URL would percent-encode the braces)
      const brace = rel.indexOf("{");
      f.href = brace < 0 ? new URL(rel, target).href : new URL(rel.slice(0, brace), target).href + rel.slice(brace);
    }
  };
  fix(doc.forms);
  for (const kind of ["properties", "actions", "events"]) {
    for (const a of Object.values((doc[kind] ?? {}) as Record<string, { forms?: unknown }>)) fix(a.forms);
  }
  doc.base = target;
  return td;
}

function defaultDescription(model: RobotModelLike, joints: JointSpec[], summary: WorkspaceSummary | null, tool?: { flange: string }): string {
  let text = `Digital twin of the robot arm '${model.name}' (${joints.length} controllable joints, end effector '${model.eeLink}'${tool ? `: the TCP of a tool on '${tool.flange}'` : ""}), simulated with PyBullet.`;
  if (summary) {
    text += ` Workspace: ${summary.samples} sampled configurations, ${summary.collisionFree} collision-free, ${summary.method} of volume ${summary.volume.toFixed(4)} m³.`;
  }
  return text;
}
