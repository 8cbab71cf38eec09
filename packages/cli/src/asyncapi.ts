/**
 * AsyncAPI 3.0 document of a twin's streams, from its TD: what the TD's forms cannot say about them.
 *
 * - The `/live` WebSocket (the TD's `robwot:live` link; its protocol is the servient's own, Contract 4):
 *   the client sends `subscribe` / `unsubscribe` (with `resume` by sequence number), the servient sends
 *   `joints`, `status`, `scene`, `collision`, `divergence`, `collisionImminent`, `physical`, `gap` and
 *   `error` messages. The payloads reuse the TD's own data schemas (the joints, the motion status, each
 *   event's data, `physicalState`) inside the message envelope (`thing`, `type`, `seq`).
 * - Every Server-Sent Events form of the TD (`subprotocol: "sse"`, W3C WoT Profile): one channel each,
 *   the property's or the event's data schema as the message payload (`text/event-stream` framing: the
 *   `data:` field holds the JSON, `id:` increases per stream, `Last-Event-ID` resumes).
 *
 * TD data schemas become AsyncAPI schemas (JSON Schema draft 7): every term JSON Schema has no keyword
 * for (`unit`, `@type`, ...) is kept as an `x-<term>` extension, the affordance terms (`forms`, ...) are
 * dropped. The result is validated by the official parser (`@asyncapi/parser`).
 */
import { createRequire } from "node:module";

type Json = Record<string, unknown>;
const require = createRequire(import.meta.url);

const isObject = (v: unknown): v is Json => typeof v === "object" && v !== null && !Array.isArray(v);

/** Keywords of JSON Schema draft 7 and AsyncAPI's Schema Object. */
const SCHEMA_KEYWORDS = new Set([
  "$id", "$ref", "$comment", "title", "description", "default", "readOnly", "writeOnly", "examples", "multipleOf", "maximum",
  "exclusiveMaximum", "minimum", "exclusiveMinimum", "maxLength", "minLength", "pattern", "additionalItems", "items", "maxItems",
  "minItems", "uniqueItems", "contains", "maxProperties", "minProperties", "required", "additionalProperties", "definitions",
  "properties", "patternProperties", "dependencies", "propertyNames", "const", "enum", "type", "format", "contentMediaType",
  "contentEncoding", "if", "then", "else", "allOf", "anyOf", "oneOf", "not", "discriminator", "externalDocs", "deprecated",
]);
/** Terms of an interaction affordance that are not part of its data schema. */
const AFFORDANCE_TERMS = new Set(["forms", "observable", "uriVariables", "input", "output", "safe", "idempotent", "synchronous", "data", "dataResponse", "subscription", "cancellation"]);
/** Keywords whose value is one schema, a list of schemas, or a map of schemas. */
const ONE = new Set(["items", "additionalProperties", "not", "contains", "propertyNames", "if", "then", "else", "additionalItems"]);
const LIST = new Set(["allOf", "anyOf", "oneOf"]);
const MAP = new Set(["properties", "patternProperties", "definitions"]);

/** A TD data schema as an AsyncAPI (JSON Schema draft 7) schema; see the module comment. */
export function toAsyncSchema(schema: unknown): Json {
  if (!isObject(schema)) return {};
  const out: Json = {};
  for (const [k, v] of Object.entries(schema)) {
    if (AFFORDANCE_TERMS.has(k)) continue;
    if (!SCHEMA_KEYWORDS.has(k)) out[`x-${k.replace(/^@/, "")}`] = v;
    else if (ONE.has(k) && isObject(v)) out[k] = toAsyncSchema(v);
    else if (LIST.has(k) && Array.isArray(v)) out[k] = v.map(toAsyncSchema);
    else if (MAP.has(k) && isObject(v)) out[k] = Object.fromEntries(Object.entries(v).map(([n, s]) => [n, toAsyncSchema(s)]));
    else out[k] = v;
  }
  return out;
}

const forms = (affordance: unknown): Json[] => (isObject(affordance) && Array.isArray(affordance["forms"]) ? (affordance["forms"] as unknown[]).filter(isObject) : []);

/** The `/live` envelope around a payload of the TD: `{thing, type, seq}` and the payload's own members. */
function liveMessage(type: string, summary: string, payload: Json | null, extra: Json = {}): Json {
  const envelope: Json = {
    type: "object",
    required: ["thing", "type"],
    properties: {
      thing: { type: "string", description: "the twin's slug" },
      type: { const: type },
      seq: { type: "integer", minimum: 1, description: "the servient's sequence number of this message (resume after it)" },
      ...extra,
    },
  };
  return { name: type, summary, contentType: "application/json", payload: payload ? { allOf: [envelope, payload] } : envelope };
}

/** The servers, channels and operations of the document, filled in document order. */
interface Parts {
  servers: Json;
  channels: Json;
  operations: Json;
  /** the `security` member of each server: the TD's schemes, or nothing when the TD has none */
  secured: Json;
}

/** The AsyncAPI 3.0 document of the twin whose TD (forms absolute, at the served address) is `td`. */
export async function thingAsyncApi(td: Json): Promise<Json> {
  const properties = isObject(td["properties"]) ? td["properties"] : {};
  const events = isObject(td["events"]) ? td["events"] : {};
  const title = String(td["title"] ?? "twin");
  const security = securitySchemes(td);
  const secured = Object.keys(security).length > 0 ? { security: Object.keys(security).map((n) => ({ $ref: `#/components/securitySchemes/${n}` })) } : {};
  const parts: Parts = { servers: {}, channels: {}, operations: {}, secured };

  const live = (Array.isArray(td["links"]) ? (td["links"] as unknown[]) : []).find((l) => isObject(l) && l["rel"] === "robwot:live") as Json | undefined;
  if (live && typeof live["href"] === "string") addLive(parts, new URL(live["href"]), properties, events);
  for (const [name, p] of Object.entries(properties)) addSse(parts, "properties", name, p, toAsyncSchema(p));
  for (const [name, e] of Object.entries(events)) addSse(parts, "events", name, e, isObject(e) ? toAsyncSchema(e["data"]) : {});

  const doc: Json = {
    asyncapi: "3.0.0",
    info: {
      title: `${title} streams`,
      version: String((isObject(td["version"]) ? td["version"]["instance"] : undefined) ?? "1.0.0"),
      description: `The live WebSocket and the Server-Sent Events streams of the RobWoT twin ${title} (its TD: ${String(td["id"] ?? "")}). Units: metres, radians, seconds.`,
    },
    defaultContentType: "application/json",
    servers: parts.servers,
    channels: parts.channels,
    operations: parts.operations,
    ...(Object.keys(security).length > 0 ? { components: { securitySchemes: security } } : {}),
  };
  const errors = await validateAsyncApi(doc);
  if (errors.length > 0) throw new Error(`the AsyncAPI document does not validate: ${errors.slice(0, 5).join("; ")}`);
  return doc;
}

/** The `/live` WebSocket at `url`: its server, its channel and one operation per direction. */
function addLive(parts: Parts, url: URL, properties: Json, events: Json): void {
  parts.servers["live"] = { host: url.host, protocol: url.protocol.replace(":", ""), pathname: url.pathname, description: "the servient's /live WebSocket", ...parts.secured };
  const received = liveReceived(properties, events);
  const sent = liveSent();
  const all = { ...received, ...sent };
  parts.channels["live"] = {
    address: null,
    servers: [{ $ref: "#/servers/live" }],
    description: "The servient's own live protocol (ws://host:port/live?thing=<slug>&resume=<seq> subscribes at once)",
    messages: Object.fromEntries(Object.entries(all).map(([n, m]) => [n, m])),
  };
  parts.operations["receiveLive"] = { action: "receive", channel: { $ref: "#/channels/live" }, messages: Object.keys(received).map((n) => ({ $ref: `#/channels/live/messages/${n}` })) };
  parts.operations["sendLive"] = { action: "send", channel: { $ref: "#/channels/live" }, messages: Object.keys(sent).map((n) => ({ $ref: `#/channels/live/messages/${n}` })) };
}

/** The messages the servient sends on `/live`, their payloads the TD's own data schemas. */
function liveReceived(properties: Json, events: Json): Record<string, Json> {
  const schema = (name: string): Json | null => (isObject(properties[name]) ? toAsyncSchema(properties[name]) : null);
  const eventData = (name: string): Json | null => (isObject(events[name]) && isObject((events[name] as Json)["data"]) ? toAsyncSchema((events[name] as Json)["data"]) : null);
  const vector = { type: "object", properties: { x: { type: "number" }, y: { type: "number" }, z: { type: "number" } }, required: ["x", "y", "z"], "x-unit": "m" };
  const received: Record<string, Json> = {
    joints: liveMessage("joints", "the joints and end-effector pose, at least 30 per second of simulated time while moving", null, {
      time: { type: "number", minimum: 0, "x-unit": "s" },
      joints: schema("getJointPosition") ?? { type: "object" },
      position: vector,
      orientation: { type: "object", properties: { x: { type: "number" }, y: { type: "number" }, z: { type: "number" }, w: { type: "number" } } },
    }),
    status: liveMessage("status", "the motion status (motionStatus) after every change", schema("motionStatus")),
    scene: liveMessage("scene", "the shared world's obstacles (scene.json's shape) and objects where they rest (the objects property) after every scene edit", null, {
      obstacles: { type: "array", items: { type: "object" } },
      objects: schema("objects") ?? { type: "array", items: { type: "object" } },
      conveyors: { type: "array", items: { type: "object" }, description: "(a world with conveyors) each belt as scene.json states it: box size, position, orientation, speed, state" },
    }),
    gap: liveMessage("gap", "events after `resume` are no longer known (sent first, without seq)", null, {
      resume: { type: "integer", minimum: 0 },
      firstKept: { type: "integer", minimum: 0 },
      reason: { type: "string", enum: ["overflow", "restart"] },
    }),
    error: {
      name: "error",
      summary: "a client message the servient could not take",
      contentType: "application/json",
      payload: { type: "object", required: ["type", "code", "message"], properties: { type: { const: "error" }, code: { type: "string" }, message: { type: "string" }, details: { type: "object" } } },
    },
  };
  for (const name of Object.keys(events)) received[name] = liveMessage(name, `the ${name} event`, eventData(name));
  if (isObject(properties["physicalState"])) received["physical"] = liveMessage("physical", "each reading of the followed physical robot (physicalState)", schema("physicalState"));
  return received;
}

/** The messages a client sends on `/live` (fresh objects: each document owns its own). */
const liveSent = (): Record<string, Json> => ({
  subscribe: {
    name: "subscribe",
    summary: "follow a twin (or every twin: \"*\"); resume replays the kept events after that seq, then a snapshot follows",
    contentType: "application/json",
    payload: { type: "object", required: ["subscribe"], properties: { subscribe: { type: "string" }, resume: { type: "integer", minimum: 0 } }, additionalProperties: false },
  },
  unsubscribe: {
    name: "unsubscribe",
    summary: "stop following a twin",
    contentType: "application/json",
    payload: { type: "object", required: ["unsubscribe"], properties: { unsubscribe: { type: "string" } }, additionalProperties: false },
  },
});

/** One channel and one receive operation per Server-Sent Events form of an affordance. */
function addSse(parts: Parts, kind: "properties" | "events", name: string, affordance: unknown, payload: Json): void {
  for (const form of forms(affordance)) {
    if (form["subprotocol"] !== "sse" || typeof form["href"] !== "string") continue;
    const url = new URL(form["href"]);
    parts.servers["http"] ??= { host: url.host, protocol: url.protocol.replace(":", ""), description: "the servient's HTTP server (Server-Sent Events, text/event-stream)", ...parts.secured };
    const id = `${kind}.${name}`;
    parts.channels[id] = {
      address: url.pathname,
      servers: [{ $ref: "#/servers/http" }],
      description: `Server-Sent Events of the ${kind === "properties" ? "property" : "event"} ${name}: each data: field one JSON value, id: increasing per stream; Last-Event-ID resumes`,
      messages: { [name]: { name, contentType: form["contentType"] ?? "application/json", payload } },
    };
    parts.operations[`receive.${id}`] = { action: "receive", channel: { $ref: `#/channels/${id}` }, messages: [{ $ref: `#/channels/${id}/messages/${name}` }] };
  }
}

/** The TD's basic or bearer security as AsyncAPI HTTP security schemes. */
function securitySchemes(td: Json): Json {
  const defs = isObject(td["securityDefinitions"]) ? td["securityDefinitions"] : {};
  const out: Json = {};
  for (const [name, d] of Object.entries(defs)) {
    if (!isObject(d)) continue;
    if (d["scheme"] === "basic") out[name] = { type: "http", scheme: "basic" };
    if (d["scheme"] === "bearer") out[name] = { type: "http", scheme: "bearer" };
  }
  return out;
}

interface Diagnostic {
  message: string;
  path: (string | number)[];
  severity: number;
}

/** Errors of the official AsyncAPI parser (its severity 0) on `doc`; empty when it is valid. */
export async function validateAsyncApi(doc: unknown): Promise<string[]> {
  const { Parser } = require("@asyncapi/parser") as { Parser: new () => { validate(d: string): Promise<Diagnostic[]> } };
  const diagnostics = await new Parser().validate(JSON.stringify(doc));
  return diagnostics.filter((d) => d.severity === 0).map((d) => `${d.path.join(".") || "(document)"}: ${d.message}`);
}
