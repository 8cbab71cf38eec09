/**
 * OpenAPI 3.0 document of a twin's HTTP API, made by the official converter of the W3C WoT playground
 * (`@thing-description-playground/td_to_openapi`, CommonJS, loaded through `createRequire`) and then
 * corrected where the converter is wrong for a valid TD:
 *
 * 1. It copies nested data schemas verbatim, with TD terms OpenAPI 3.0 has no place for (`unit`,
 *    `const`, a numeric `exclusiveMinimum`): its own validation then rejects its output. It is given the
 *    TD with every data schema already translated (`toOasSchema`), which it accepts.
 * 2. At the top of a schema it keeps only a few keywords (no `additionalProperties`, `description`,
 *    `default`, `minLength`, `exclusiveMinimum`, ...), takes an event's response from the affordance
 *    instead of its `data`, gives a readallproperties response no schema and an action without input an
 *    empty request body: every operation gets the complete translated schemas of its affordance.
 * 3. It ignores `additionalResponses`: each becomes the response of its `htv:statusCodeValue` (or
 *    `default` without one) with the TD's schema definition (`components.schemas`); the converter's
 *    catch-all `default` goes where the TD lists the statuses.
 * 4. It names the TD's `base` (`http://host/<slug>/`) as the server while its paths start at the host's
 *    root (`/<slug>/properties/...`), so base + path repeats the slug: the server is the base's origin.
 *    (`--base`: the servient's URL, or the Thing's own `http://host/<slug>/`; the slug is not added twice.)
 * 5. Its examples are faked (json-schema-faker, random) from the truncated schemas: dropped.
 * 6. It leaves out the Server-Sent Events forms (it maps only long-poll observation to `GET`).
 * 7. It turns an action's `uriVariables` into a query parameter of every operation of the action (with
 *    a faked example): a variable is a required path parameter where the path holds its template
 *    (`actions/<name>/{actionID}`), nothing elsewhere. Forms on one path and method merge: the moves'
 *    synchronous form answers 200 with the output, the `Prefer: respond-async` form (its `htv:headers`
 *    become a header parameter) 201 with the ActionStatus; queryaction answers the ActionStatus its
 *    `additionalResponses` declare, cancelaction 204 without a body.
 * 8. The 201 declares its `Location` header and OpenAPI `links` to the queryaction and cancelaction
 *    operations (`operationId` `queryaction_<name>` / `cancelaction_<name>`, `actionID` from the body's
 *    `id`), so a stateful client (Schemathesis) can chain them. A form's `htv:headers` value is an
 *    example, not an enum: the `Prefer` header holds RFC 7240 preferences, and unknown ones are ignored.
 *
 * The result is validated against the OpenAPI 3.0 JSON Schema (`@seriousme/openapi-schema-validator`).
 */
import { createRequire } from "node:module";
import { PROBLEM_JSON } from "@robwot/core";
import { placeTd } from "./td.js";

type Json = Record<string, unknown>;
const require = createRequire(import.meta.url);

interface Converter {
  (td: Json): Promise<{ json: Json; yaml: string }>;
}

/** Keywords of an OpenAPI 3.0 Schema Object (besides `x-` extensions). */
const OAS_SCHEMA_KEYWORDS = new Set([
  "title", "multipleOf", "maximum", "exclusiveMaximum", "minimum", "exclusiveMinimum", "maxLength", "minLength", "pattern",
  "maxItems", "minItems", "uniqueItems", "maxProperties", "minProperties", "required", "enum", "type", "allOf", "oneOf",
  "anyOf", "not", "items", "properties", "additionalProperties", "description", "format", "default", "nullable",
  "discriminator", "readOnly", "writeOnly", "xml", "externalDocs", "example", "deprecated",
]);
/** Terms of an interaction affordance that are not part of its data schema. */
const AFFORDANCE_TERMS = new Set(["forms", "observable", "uriVariables", "input", "output", "safe", "idempotent", "synchronous", "data", "dataResponse", "subscription", "cancellation"]);

const isObject = (v: unknown): v is Json => typeof v === "object" && v !== null && !Array.isArray(v);

/**
 * A TD data schema as an OpenAPI 3.0 Schema Object: `const` → one-value `enum`, numeric
 * `exclusiveMinimum`/`exclusiveMaximum` → the bound with the boolean flag, `type: "null"` → `nullable`,
 * and every term OpenAPI has no keyword for (`unit`, `@type`, `titles`, ...) kept as `x-<term>`.
 */
export function toOasSchema(schema: unknown): Json {
  if (!isObject(schema)) return {};
  const out: Json = {};
  for (const [k, v] of Object.entries(schema)) {
    if (k === "properties" && isObject(v)) out[k] = Object.fromEntries(Object.entries(v).map(([n, p]) => [n, toOasSchema(p)]));
    else if ((k === "items" || k === "not") && isObject(v)) out[k] = toOasSchema(v);
    else if (k === "items" && Array.isArray(v)) out[k] = { anyOf: v.map(toOasSchema) }; // tuple: OpenAPI 3.0 has none
    else if ((k === "oneOf" || k === "anyOf" || k === "allOf") && Array.isArray(v)) out[k] = v.map(toOasSchema);
    else if (k === "additionalProperties") out[k] = isObject(v) ? toOasSchema(v) : v;
    else if (k === "const") out["enum"] = [v];
    else if (k === "type" && v === "null") out["nullable"] = true;
    else if ((k === "exclusiveMinimum" || k === "exclusiveMaximum") && typeof v === "number") continue; // below
    else if (OAS_SCHEMA_KEYWORDS.has(k) || k.startsWith("x-")) out[k] = v;
    else out[`x-${k}`] = v;
  }
  for (const [exclusive, inclusive, tighter] of [
    ["exclusiveMinimum", "minimum", (a: number, b: number) => a >= b],
    ["exclusiveMaximum", "maximum", (a: number, b: number) => a <= b],
  ] as const) {
    const e = schema[exclusive];
    if (typeof e !== "number") continue;
    const i = schema[inclusive];
    // value > e and value >= i: the inclusive bound decides when it is the tighter one
    if (typeof i === "number" && i !== e && tighter(i, e)) continue;
    out[inclusive] = e;
    out[exclusive] = true;
  }
  return out;
}

/** The data schema of a property affordance (the affordance without its interaction terms). */
function dataPart(affordance: Json): Json {
  return Object.fromEntries(Object.entries(affordance).filter(([k]) => !AFFORDANCE_TERMS.has(k)));
}

/** The TD with every data schema translated, for the converter (it copies nested schemas as they are). */
function forConverter(td: Json): Json {
  const copy = structuredClone(td);
  const each = (kind: string, fn: (a: Json) => Json): void => {
    const all = copy[kind];
    if (!isObject(all)) return;
    for (const [name, a] of Object.entries(all)) if (isObject(a)) all[name] = fn(a);
  };
  const withSchemas = (a: Json, keys: string[]): Json => {
    const r: Json = { ...a };
    for (const k of keys) if (isObject(a[k])) r[k] = toOasSchema(a[k]);
    if (isObject(a["uriVariables"])) r["uriVariables"] = Object.fromEntries(Object.entries(a["uriVariables"]).map(([n, s]) => [n, toOasSchema(s)]));
    return r;
  };
  each("properties", (p) => ({ ...withSchemas(p, []), ...toOasSchema(dataPart(p)), forms: p["forms"] }));
  each("actions", (a) => withSchemas(a, ["input", "output"]));
  each("events", (e) => withSchemas(e, ["data", "subscription", "cancellation"]));
  return copy;
}

const METHOD_OF_OP: Record<string, string> = {
  readproperty: "get",
  writeproperty: "put",
  invokeaction: "post",
  readallproperties: "get",
  writeallproperties: "put",
  readmultipleproperties: "get",
  writemultipleproperties: "put",
};

/** Where the converter puts a form: its URL path and HTTP methods (its own rules, crawlPaths.js). */
function formOperations(form: Json): { path: string; methods: string[] } | null {
  const href = form["href"];
  if (typeof href !== "string" || !/^https?:\/\//.test(href)) return null;
  const path = `/${href.replace(/^https?:\/\//, "").split("/").slice(1).join("/")}`;
  const method = form["htv:methodName"];
  if (typeof method === "string" && ["GET", "PUT", "POST", "DELETE", "PATCH"].includes(method)) return { path, methods: [method.toLowerCase()] };
  const ops = typeof form["op"] === "string" ? [form["op"]] : Array.isArray(form["op"]) ? (form["op"] as string[]) : [];
  const methods = [...new Set(ops.map((o) => METHOD_OF_OP[o]).filter((m): m is string => m !== undefined))];
  if (methods.length === 0 && form["subprotocol"] === "longpoll") methods.push("get");
  return { path, methods };
}

const STATUS_TEXT: Record<number, string> = {
  400: "bad input: malformed JSON or a schema violation",
  404: "no such obstacle (or path)",
  409: "busy: the twin is moving, or the obstacle name is taken",
  413: "request body too large",
  415: "the request body is not JSON",
  422: "rejected by simulation-in-the-loop validation",
  503: "the simulation backend is down or restarting",
  504: "the simulation backend did not answer in time",
};

/** The converted document's operation for a method and path, or undefined. */
function operation(doc: Json, path: string, method: string): Json | undefined {
  const item = (doc["paths"] as Record<string, Json | undefined>)[path];
  const op = item?.[method];
  return isObject(op) ? op : undefined;
}

function jsonContent(contentType: string, schema: Json): Json {
  return { [contentType]: { schema } };
}

/** Responses of a form's `additionalResponses`: error answers (success: false) and declared success
 * answers (success: true, e.g. the ActionStatus of an asynchronous invocation or of a query). */
function declaredResponses(form: Json, schemaRef: (name: unknown) => Json): { responses: Record<string, Json>; listed: boolean; success: boolean } {
  const responses: Record<string, Json> = {};
  let listed = false;
  let success = false;
  const extra = Array.isArray(form["additionalResponses"]) ? (form["additionalResponses"] as unknown[]) : [];
  for (const r of extra) {
    if (!isObject(r)) continue;
    const status = r["htv:statusCodeValue"];
    const key = typeof status === "number" ? String(status) : "default";
    if (key !== "default") listed = true;
    const type = typeof r["contentType"] === "string" ? r["contentType"] : typeof form["contentType"] === "string" ? form["contentType"] : "application/json";
    const ok = r["success"] === true;
    success ||= ok;
    const description = ok ? "success" : typeof status === "number" ? (STATUS_TEXT[status] ?? `error ${status}`) : "an error answer";
    responses[key] = { description, content: jsonContent(type, schemaRef(r["schema"])) };
  }
  return { responses, listed, success };
}

/**
 * (7) The action's `uriVariables` (e.g. `actionID` of the queryaction/cancelaction forms on
 * `actions/<name>/{actionID}`): the converter makes each a query parameter of every operation of the
 * action, with a faked example. A variable is a required path parameter where the path holds its
 * template, and no parameter elsewhere.
 */
function fixUriVariables(op: Json, path: string, variables: string[]): void {
  const params = Array.isArray(op["parameters"]) ? (op["parameters"] as Json[]) : [];
  const kept: Json[] = [];
  for (const p of params) {
    const { example: _faked, ...rest } = p;
    const name = typeof p["name"] === "string" ? p["name"] : "";
    if (!variables.includes(name)) kept.push(p);
    else if (path.includes(`{${name}}`)) kept.push({ ...rest, in: "path", required: true });
  }
  if (kept.length > 0) op["parameters"] = kept;
  else delete op["parameters"];
}

/**
 * (6) A Server-Sent Events form (WoT Profile, `subprotocol: "sse"`): the converter knows long-poll only
 * and leaves it out. `GET` answers `text/event-stream`; each event's `data` is one JSON value of the
 * affordance's schema (`x-data-schema`: OpenAPI 3.0 cannot type the events of a stream).
 */
function addEventStream(doc: Json, path: string, form: Json, data: Json | null): void {
  const paths = doc["paths"] as Record<string, Json>;
  const op: Json = {
    tags: [String(path.split("/").at(-3) ?? "properties")],
    summary: `${String(path.split("/").at(-2))} as Server-Sent Events`,
    description: `op: ${(Array.isArray(form["op"]) ? form["op"] : [form["op"]]).join(", ")}; subprotocol: sse`,
    responses: {
      "200": {
        description: "a stream of events; each data field is one JSON value of x-data-schema",
        content: { "text/event-stream": { schema: { type: "string", ...(data ? { "x-data-schema": data } : {}) } } },
      },
    },
  };
  paths[path] = { ...(paths[path] ?? {}), get: op };
}

const PREFER_NOTE = " (RFC 7240 preferences: respond-async asks for the asynchronous answer, others are ignored)";

/** `/<slug>/actions/<name>/{actionID}` -> `<name>` */
const actionName = (path: string): string => path.split("/").at(-2) ?? "";

/**
 * (8) The asynchronous invocation's 201: its `Location` header, and links from its ActionStatus to the
 * queryaction and cancelaction operations of the same invocation.
 */
function linkStatus(doc: Json, name: string, forms: Json[]): void {
  const invoke = forms.find((f) => isObject(f["response"]) && f["response"]["htv:statusCodeValue"] === 201);
  const where = invoke ? formOperations(invoke) : null;
  const created = where ? (operation(doc, where.path, "post")?.["responses"] as Json | undefined)?.["201"] : undefined;
  if (!isObject(created)) return;
  created["headers"] = {
    Location: { description: "URL of the ActionStatus resource (also its href)", required: true, schema: { type: "string", format: "uri" } },
  };
  const links: Json = {};
  for (const op of ["queryaction", "cancelaction"]) {
    const form = forms.find((f) => (Array.isArray(f["op"]) ? f["op"] : [f["op"]]).includes(op));
    const at = form ? formOperations(form) : null;
    if (!at) continue;
    const variable = /\{(\w+)\}/.exec(at.path)?.[1];
    if (!variable) continue;
    links[op] = {
      operationId: `${op}_${name}`,
      parameters: { [variable]: "$response.body#/id" },
      description: op === "queryaction" ? "the status of this invocation" : "cancels this invocation",
    };
  }
  if (Object.keys(links).length > 0) created["links"] = links;
}

export interface OpenApiOptions {
  /** URL of the servient: the forms move to `<base>/<slug>/` first, as `robwot serve` moves them. */
  base?: string;
}

/** What the corrections of one document share. */
interface Correcting {
  doc: Json;
  /** the TD's `schemaDefinitions` */
  definitions: Json;
  /** "<method> <path>" already given its success answer by a form */
  filled: Set<string>;
}

const CONTENT_TYPE = "application/json";

/** The official converter's document for `td`, corrected (see the module comment) and validated. */
export async function thingOpenApi(tdIn: Json, options: OpenApiOptions = {}): Promise<Json> {
  // the Thing lives at <servient>/<slug>/ (node-wot's layout); `--base http://host/<slug>/` names it
  const td = options.base !== undefined ? placeTd(tdIn, options.base) : structuredClone(tdIn);
  const toOpenAPI = require("@thing-description-playground/td_to_openapi") as Converter;
  let converted: Json;
  try {
    converted = (await toOpenAPI(forConverter(td))).json;
  } catch (err) {
    throw new Error(`the official converter rejected its own output: ${err instanceof Error ? err.message.trim() : String(err)}`);
  }
  const doc = structuredClone(converted);

  // (3) the TD's schema definitions, referenced by the error answers
  const definitions = isObject(td["schemaDefinitions"]) ? td["schemaDefinitions"] : {};
  const components = (doc["components"] ?? {}) as Json;
  components["schemas"] = Object.fromEntries(Object.entries(definitions).map(([n, s]) => [n, toOasSchema(s)]));
  doc["components"] = components;

  fillAffordances({ doc, definitions, filled: new Set<string>() }, td);
  oneServer(doc, td);
  const problems = await validateOpenApi(doc);
  if (problems.length > 0) throw new Error(`the corrected OpenAPI document is not valid: ${problems.slice(0, 3).join("; ")}`);
  return doc;
}

/** Every form of the TD corrected in place: properties, actions, events, then the Thing's own forms. */
function fillAffordances(c: Correcting, td: Json): void {
  const properties = isObject(td["properties"]) ? td["properties"] : {};
  for (const p of Object.values(properties)) {
    if (!isObject(p)) continue;
    for (const form of (p["forms"] ?? []) as Json[]) fillForm(c, form, toOasSchema(dataPart(p)), null);
  }
  const actions = isObject(td["actions"]) ? td["actions"] : {};
  for (const a of Object.values(actions)) {
    if (!isObject(a)) continue;
    const variables = isObject(a["uriVariables"]) ? Object.keys(a["uriVariables"]) : [];
    for (const form of (a["forms"] ?? []) as Json[]) fillForm(c, form, isObject(a["output"]) ? toOasSchema(a["output"]) : null, isObject(a["input"]) ? toOasSchema(a["input"]) : null, variables);
  }
  const events = isObject(td["events"]) ? td["events"] : {};
  for (const e of Object.values(events)) {
    if (!isObject(e)) continue;
    for (const form of (e["forms"] ?? []) as Json[]) fillForm(c, form, isObject(e["data"]) ? toOasSchema(e["data"]) : null, null);
  }
  for (const [name, a] of Object.entries(actions)) if (isObject(a)) linkStatus(c.doc, name, (a["forms"] ?? []) as Json[]);
  // readallproperties: every readable property by name (node-wot's answer)
  const readable = Object.entries(properties).filter(([, p]) => isObject(p) && p["writeOnly"] !== true);
  const all: Json = {
    type: "object",
    properties: Object.fromEntries(readable.map(([n, p]) => [n, toOasSchema(dataPart(p as Json))])),
    required: readable.map(([n]) => n),
  };
  for (const form of (Array.isArray(td["forms"]) ? td["forms"] : []) as Json[]) fillForm(c, form, all, null);
}

/** The operations of one form: their answers, request body, header parameters and URI variables. */
function fillForm(c: Correcting, form: Json, response: Json | null, request: Json | null, variables: string[] = []): void {
  const where = formOperations(form);
  if (!where) return;
  if (where.methods.length === 0 && form["subprotocol"] === "sse") {
    addEventStream(c.doc, where.path, form, response);
    return;
  }
  const ops = typeof form["op"] === "string" ? [form["op"]] : Array.isArray(form["op"]) ? (form["op"] as string[]) : [];
  const onStatus = ops.includes("queryaction") || ops.includes("cancelaction");
  for (const method of where.methods) {
    const op = operation(c.doc, where.path, method);
    if (!op) continue;
    const type = typeof form["contentType"] === "string" ? form["contentType"] : CONTENT_TYPE;
    fillResponses(c, op, method, where.path, form, ops, response, type);
    if (method === "get" || method === "delete" || onStatus || !request) delete op["requestBody"];
    else op["requestBody"] = { required: true, content: jsonContent(type, request) };
    addHeaderParameters(op, form);
    fixUriVariables(op, where.path, variables);
  }
}

/**
 * (2), (5) An operation's answers from its form: the success answer with the complete schema and no faked
 * example, the form's declared answers, the error body every error answer of this TD has. A second form of
 * the same operation adds its answers without replacing the first one's.
 */
function fillResponses(c: Correcting, op: Json, method: string, path: string, form: Json, ops: string[], response: Json | null, type: string): void {
  const key = `${method} ${path}`;
  const schemaRef = (name: unknown): Json => (typeof name === "string" && name in c.definitions ? { $ref: `#/components/schemas/${name}` } : {});
  const responses = (op["responses"] ?? {}) as Json;
  const declared = declaredResponses(form, schemaRef);
  if (!c.filled.has(key)) delete responses["200"]; // the converter's guess; a form names the real one
  if (!declared.success) {
    // a form's `response` may name another status
    const expected = isObject(form["response"]) ? form["response"] : {};
    const status = typeof expected["htv:statusCodeValue"] === "number" ? String(expected["htv:statusCodeValue"]) : "200";
    const responseType = typeof expected["contentType"] === "string" ? expected["contentType"] : type;
    responses[status] = { description: "success", ...(response ? { content: jsonContent(responseType, response) } : {}) };
  }
  if (ops.includes("cancelaction")) {
    // the WoT Profile's answer: no body (the converter's guess carried the action's output)
    responses["204"] = { description: "cancelled: the move has stopped and its ActionStatus is deleted (a query then answers 404)" };
    op["operationId"] = `cancelaction_${actionName(path)}`;
  }
  if (ops.includes("queryaction")) op["operationId"] = `queryaction_${actionName(path)}`;
  if (declared.listed) delete responses["default"];
  else if (isObject(responses["default"]) && "error" in c.definitions) {
    // the converter's catch-all, with the body every error answer of this TD has
    responses["default"] = { description: "an error answer", content: jsonContent(PROBLEM_JSON, schemaRef("error")) };
  }
  for (const [status, answer] of Object.entries(declared.responses)) {
    if (!(status in responses) || !c.filled.has(key) || declared.success) responses[status] = answer;
  }
  op["responses"] = responses;
  c.filled.add(key);
}

/** The form's `htv:headers` as optional header parameters of the operation (once each). */
function addHeaderParameters(op: Json, form: Json): void {
  const headers = Array.isArray(form["htv:headers"]) ? (form["htv:headers"] as Json[]) : [];
  for (const h of headers) {
    const name = h["htv:fieldName"];
    if (typeof name !== "string") continue;
    const params = Array.isArray(op["parameters"]) ? (op["parameters"] as Json[]) : [];
    if (params.some((p) => p["in"] === "header" && p["name"] === name)) continue;
    const value = typeof h["htv:fieldValue"] === "string" ? h["htv:fieldValue"] : undefined;
    const answers = String((isObject(form["response"]) && form["response"]["htv:statusCodeValue"]) ?? "");
    const description = `${value ?? "the value"}: the form answering ${answers}` + (name.toLowerCase() === "prefer" ? PREFER_NOTE : "");
    // RFC 7240: a preference the server does not know is ignored, so any value is a valid header
    op["parameters"] = [...params, { name, in: "header", required: false, description, schema: { type: "string" }, ...(value ? { example: value } : {}) }];
  }
}

/** (4) One server, the origin the paths start from; per-operation copies of it are redundant. */
function oneServer(doc: Json, td: Json): void {
  const base = typeof td["base"] === "string" ? td["base"] : undefined;
  if (base === undefined || !/^https?:\/\//.test(base)) return;
  const origin = new URL(base).origin;
  doc["servers"] = [{ url: origin, description: `the servient of ${String(td["title"] ?? "the Thing")} (Thing at ${base})` }];
  for (const item of Object.values(doc["paths"] as Record<string, Json>)) {
    for (const op of Object.values(item)) {
      if (!isObject(op)) continue;
      const servers = op["servers"];
      if (Array.isArray(servers) && servers.length === 1 && isObject(servers[0]) && servers[0]["url"] === origin) delete op["servers"];
    }
  }
}

/** Errors of `doc` against the OpenAPI JSON Schema (empty when valid). */
export async function validateOpenApi(doc: unknown): Promise<string[]> {
  const { Validator } = (await import("@seriousme/openapi-schema-validator")) as typeof import("@seriousme/openapi-schema-validator");
  const result = await new Validator().validate(doc as Parameters<InstanceType<typeof Validator>["validate"]>[0]);
  if (result.valid) return [];
  const errors = Array.isArray(result.errors) ? result.errors : [{ message: String(result.errors) }];
  return errors.map((e: { instancePath?: string; message?: string }) => `${e.instancePath ?? ""} ${e.message ?? ""}`.trim());
}
