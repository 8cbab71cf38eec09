#!/usr/bin/env node
/**
 * Generates, from the backend's one contract (`sim-backend/src/robwot_sim/schemas/protocol.openrpc.json`):
 *   - `packages/core/src/backend-contract.ts`: TS types of every schema, method params/result and notification
 *     (json-schema-to-typescript), plus the `Methods` and `Notifications` maps the typed client is built on,
 *     and `TRANSPORT`, the clients' one timeout and heartbeat policy (`x-transport`);
 *   - `sim-backend/PROTOCOL.md`: the prose in `sim-backend/protocol/*.md` around the generated reference;
 *   - the contract-owned `$defs` of `sim-backend/src/robwot_sim/schemas/scene.schema.json` (positions, names,
 *     obstacle shapes: the scene file and the RPC params obey the same ranges);
 *   - `packages/sim-client/src/methods.generated.ts`: the typed client's methods, one per contract method,
 *     named by its `x-client`; `x-long` methods have no request timeout of their own, an `x-progress`
 *     method takes an `onProgress` listener of that notification.
 *
 * `node scripts/gen-contract.mjs` writes them (`npm run gen:contract`); `--check` exits 1 when one is
 * stale. `renderContract()` is what the staleness test compares with the files.
 */
import { readFile, writeFile } from "node:fs/promises";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { compile } from "json-schema-to-typescript";

const ROOT = join(dirname(fileURLToPath(import.meta.url)), "..");
export const CONTRACT = join(ROOT, "sim-backend/src/robwot_sim/schemas/protocol.openrpc.json");
export const TS_OUT = join(ROOT, "packages/core/src/backend-contract.ts");
export const MD_OUT = join(ROOT, "sim-backend/PROTOCOL.md");
export const SCENE_SCHEMA = join(ROOT, "sim-backend/src/robwot_sim/schemas/scene.schema.json");
export const CLIENT_OUT = join(ROOT, "packages/sim-client/src/methods.generated.ts");
const PROSE = join(ROOT, "sim-backend/protocol");

/** "robot.setJointPositions" -> "RobotSetJointPositions" */
const pascal = (name) => name.split(/[._]/).map((w) => w[0].toUpperCase() + w.slice(1)).join("");
const refName = (ref) => ref.split("/").pop();

/** Deep copy with `#/components/schemas/X` refs pointing at `#/definitions/X`; a `$ref`'s sibling keywords
 * (description, default) are dropped, so that the type is the referenced one and not a numbered copy. */
function toDefinitions(schema) {
  if (Array.isArray(schema)) return schema.map(toDefinitions);
  if (schema === null || typeof schema !== "object") return schema;
  if (schema.$ref) return { $ref: `#/definitions/${refName(schema.$ref)}` };
  // a free-form object (a scene document) is any JSON object, not `{}`
  if (schema.type === "object" && !schema.properties && schema.additionalProperties === undefined) {
    return { ...schema, additionalProperties: true };
  }
  const out = {};
  for (const [k, v] of Object.entries(schema)) {
    out[k] = k === "$ref" ? `#/definitions/${refName(v)}` : toDefinitions(v);
  }
  return out;
}

/** A description as one JSDoc line. */
const jsdoc = (text) => text.replace(/\*\//g, "* /").replace(/\s+/g, " ");

/** `x-transport`: every client's timeouts and heartbeat, `[name, {value, description}]`, each a positive number. */
function transportPolicy(doc) {
  const entries = Object.entries(doc["x-transport"]).filter(([k]) => k !== "description");
  for (const [name, t] of entries) {
    if (!(Number.isFinite(t.value) && t.value > 0) || typeof t.description !== "string") throw new Error(`contract x-transport ${name} needs a positive value and a description`);
  }
  return entries;
}

async function renderTypes(doc) {
  const definitions = {};
  for (const [name, schema] of Object.entries(doc.components.schemas)) {
    definitions[name] = { ...toDefinitions(schema), title: name };
  }
  for (const m of doc.methods) {
    const base = pascal(m.name);
    definitions[`${base}Params`] = {
      title: `${base}Params`,
      description: `Params of \`${m.name}\`.`,
      type: "object",
      properties: Object.fromEntries(
        m.params.map((p) => [p.name, p.schema.$ref ? toDefinitions(p.schema) : { ...toDefinitions(p.schema), description: p.description }]),
      ),
      required: m.params.filter((p) => p.required).map((p) => p.name),
      additionalProperties: false,
    };
    definitions[`${base}Result`] = { allOf: [toDefinitions(m.result.schema)], title: `${base}Result`, description: `Result of \`${m.name}\`.` };
  }
  const root = { title: "RobwotSimContract", type: "object", properties: {}, additionalProperties: false, definitions };
  const body = await compile(root, "RobwotSimContract", {
    bannerComment: "",
    unreachableDefinitions: true,
    additionalProperties: false,
    format: true,
    strictIndexSignatures: true,
  });
  const errors = Object.entries(doc.components.errors).map(([name, e]) => {
    if (!Number.isInteger(e["x-http-status"])) throw new Error(`contract error ${name} has no integer x-http-status`);
    return `  ${name}: { rpcCode: ${e.code}, httpStatus: ${e["x-http-status"]} },`;
  });
  // the value schemas (numbers, strings, arrays): their ranges and lengths, for checks outside the backend
  const scalars = Object.entries(doc.components.schemas)
    .filter(([, v]) => ["number", "integer", "string", "array", "boolean"].includes(v.type))
    .map(([name, v]) => `  ${name}: ${JSON.stringify(v)},`);
  // the obstacle shape, its references resolved: the TD's scene-editing schemas are derived from it
  const deref = (schema) => {
    if (Array.isArray(schema)) return schema.map(deref);
    if (schema === null || typeof schema !== "object") return schema;
    if (schema.$ref) return deref(doc.components.schemas[refName(schema.$ref)]);
    return Object.fromEntries(Object.entries(schema).map(([k, v]) => [k, deref(v)]));
  };
  const obstacleShape = JSON.stringify(deref(doc.components.schemas.ObstacleShape));
  const transport = transportPolicy(doc).flatMap(([name, t]) => [`  /** ${jsdoc(t.description)} */`, `  ${name}: ${t.value},`]);
  const methods = doc.methods.map((m) => `  ${JSON.stringify(m.name)}: { params: ${pascal(m.name)}Params; result: ${pascal(m.name)}Result };`);
  const notes = doc["x-notifications"].map((n) => `  ${JSON.stringify(n.name)}: ${refName(n.params.$ref)};`);
  return [
    "/* eslint-disable */",
    "/**",
    " * GENERATED by `npm run gen:contract` from sim-backend/src/robwot_sim/schemas/protocol.openrpc.json — do not",
    " * edit; change the contract and regenerate. Units: m, rad, s; quaternions [x, y, z, w]; world frame Z up.",
    " */",
    "",
    body
      .replace(/\nexport interface RobwotSimContract \{\s*\}\n/, "\n")
      .replace(/\n \* This interface was referenced by `RobwotSimContract`'s JSON-Schema\n \* via the `definition` "\w+"\./g, "")
      .replace(/\n \* ?\n \*\//g, "\n */")
      .replace(/\/\*\*\n \*\/\n/g, "")
      .trim(),
    "",
    "/** Every backend method: its params and result. */",
    "export interface Methods {",
    ...methods,
    "}",
    "",
    "/** Every server-to-client notification: its params. */",
    "export interface Notifications {",
    ...notes,
    "}",
    "",
    "export type MethodName = keyof Methods;",
    "export type NotificationName = keyof Notifications;",
    "",
    "/** Every error of the contract by its string code (`error.data.code`): the JSON-RPC number and the HTTP",
    " *  status a servient answers for it (`x-http-status`). */",
    "export const ERRORS = {",
    ...errors,
    "} as const;",
    "",
    "export type ErrorCode = keyof typeof ERRORS;",
    "",
    "/** The contract's obstacle shape (`ObstacleShape`, references resolved) as data: one `oneOf` member per shape. */",
    `export const OBSTACLE_SHAPE = ${obstacleShape} as const;`,
    "",
    `/** ${jsdoc(doc["x-transport"].description)} */`,
    "export const TRANSPORT = {",
    ...transport,
    "} as const;",
    "",
    "/** The contract's value schemas (ranges, lengths, defaults) as data: what a check outside the backend uses. */",
    "export const VALUE_SCHEMAS = {",
    ...scalars,
    "} as const;",
    "",
  ].join("\n");
}

/** A compact TS-like signature of a schema, for the Markdown reference. */
function sig(schema, doc, depth = 0) {
  if (schema.$ref) return `\`${refName(schema.$ref)}\``;
  if ("const" in schema) return `\`${JSON.stringify(schema.const)}\``;
  if (schema.enum) return schema.enum.map((v) => `\`${JSON.stringify(v)}\``).join(" \\| ");
  const alts = schema.oneOf ?? schema.anyOf;
  if (alts) return alts.map((a) => sig(a, doc, depth)).join(" \\| ");
  const type = Array.isArray(schema.type) ? schema.type.join(" \\| ") : schema.type;
  if (type === "array") {
    const n = schema.minItems !== undefined && schema.minItems === schema.maxItems ? schema.minItems : undefined;
    const item = sig(schema.items ?? {}, doc, depth + 1);
    if (n !== undefined) return `[${Array(n).fill(item).join(", ")}]`;
    return `${item}[]`;
  }
  if (type === "object" && schema.properties) {
    if (depth > 1) return "object";
    const req = new Set(schema.required ?? []);
    const fields = Object.entries(schema.properties).map(([k, v]) => `${k}${req.has(k) ? "" : "?"}: ${sig(v, doc, depth + 1)}`);
    return `{${fields.join(", ")}}`;
  }
  if (type === "object" && schema.additionalProperties && typeof schema.additionalProperties === "object") {
    return `{[name]: ${sig(schema.additionalProperties, doc, depth + 1)}}`;
  }
  let text = type ?? "any";
  const bounds = [];
  if (schema.minimum !== undefined) bounds.push(`>= ${schema.minimum}`);
  if (schema.exclusiveMinimum !== undefined) bounds.push(`> ${schema.exclusiveMinimum}`);
  if (schema.maximum !== undefined) bounds.push(`<= ${schema.maximum}`);
  if (bounds.length) text += ` (${bounds.join(", ")})`;
  return text;
}

function resolve(schema, doc) {
  return schema.$ref ? doc.components.schemas[refName(schema.$ref)] : schema;
}

function renderMarkdown(doc, intro, example) {
  const out = [intro.trim(), ""];
  out.push("## Types", "", "Shared by the methods below (the contract's `components.schemas`).", "");
  for (const [name, schema] of Object.entries(doc.components.schemas)) {
    const desc = schema.description ? ` — ${schema.description}` : "";
    out.push(`- **\`${name}\`**: ${sig(schema, doc)}${desc}`);
  }
  out.push("", "## Methods", "");
  out.push(
    "Every method may also answer -32602 `E_INVALID_PARAMS` (a param against the contract: type, range,",
    "length, NaN/Infinity, missing or unknown; `data.param` names it, e.g. `positions[3]`) and -32603",
    "`E_INTERNAL` (a bug; the message says what).",
    "",
  );
  for (const m of doc.methods) {
    out.push(`### \`${m.name}\``, "", `${m.summary[0].toUpperCase()}${m.summary.slice(1)}.${m.description ? ` ${m.description}` : ""}`, "");
    if (m.params.length) {
      out.push("| param | type | | description |", "|---|---|---|---|");
      for (const p of m.params) {
        const target = resolve(p.schema, doc);
        const dflt = p.schema.default ?? target.default;
        const need = p.required ? "required" : dflt !== undefined ? `default \`${JSON.stringify(dflt)}\`` : "optional";
        out.push(`| \`${p.name}\` | ${sig(p.schema, doc)} | ${need} | ${p.description} |`);
      }
    } else {
      out.push("Params: none.");
    }
    out.push("", `Result: ${sig(m.result.schema, doc)}.`);
    if (m.errors.length) out.push(`Errors: ${m.errors.map((e) => `\`${refName(e.$ref)}\``).join(", ")}.`);
    out.push("");
  }
  out.push("## Notifications (server to client, no `id`)", "");
  for (const n of doc["x-notifications"]) {
    out.push(`### \`${n.name}\``, "", `${n.summary[0].toUpperCase()}${n.summary.slice(1)}: ${sig(resolve(n.params, doc), doc)}. ${n.description}`, "");
  }
  out.push(
    "## Errors",
    "",
    "`error.code` is the JSON-RPC number, `error.message` a readable sentence, `error.data.code` a stable",
    "string, and `error.data` carries the fields below. HTTP is the status the servient answers when a",
    "twin's request ends in that error (`x-http-status`: the servient's table is generated from it; 500 only",
    "for what is a bug of ours, never for a client's input).",
    "",
    "| code | data.code | HTTP | when | data fields |",
    "|---|---|---|---|---|",
  );
  for (const [name, e] of Object.entries(doc.components.errors)) {
    const fields = Object.keys(e.data.properties).filter((k) => k !== "code").map((k) => `\`${k}\``).join(", ");
    out.push(`| ${e.code} | ${name} | ${e["x-http-status"]} | ${e.message} | ${fields} |`);
  }
  out.push("", "## Timeouts and heartbeat (`x-transport`)", "", doc["x-transport"].description, "", "| name | ms | why |", "|---|---|---|");
  for (const [name, t] of transportPolicy(doc)) out.push(`| \`${name}\` | ${t.value} | ${t.description} |`);
  out.push("", example.trim(), "");
  return out.join("\n");
}

/** The scene schema with every `$defs` entry named after a contract component replaced by that component
 *  (its `#/components/schemas/X` references made `#/$defs/X`, which the scene schema then must hold too). */
function renderSceneSchema(doc, scene) {
  const refs = (schema) => {
    if (Array.isArray(schema)) return schema.map(refs);
    if (schema === null || typeof schema !== "object") return schema;
    return Object.fromEntries(Object.entries(schema).map(([k, v]) => [k, k === "$ref" ? `#/$defs/${refName(v)}` : refs(v)]));
  };
  const defs = {};
  for (const [name, schema] of Object.entries(scene.$defs)) {
    const owned = doc.components.schemas[name];
    defs[name] = owned ? refs(owned) : schema;
  }
  return `${JSON.stringify({ ...scene, $defs: defs }, null, 2)}\n`;
}

/** The typed client's methods: one per contract method, its `x-client` name, summary and description. */
function renderClient(doc) {
  const lines = [];
  for (const m of doc.methods) {
    const name = m["x-client"];
    if (!name) throw new Error(`contract method ${m.name} has no x-client name`);
    const optional = m.params.every((p) => !p.required);
    const doc1 = [m.summary, m.description].filter(Boolean).join(": ").replace(/\*\//g, "* /").replace(/\s+/g, " ");
    const progress = m["x-progress"];
    const opts = progress ? `options: CallOptions & { onProgress?: (p: Notifications[${JSON.stringify(progress)}]) => void } = {}` : "options: CallOptions = {}";
    lines.push(
      `  /** \`${m.name}\`: ${doc1} */`,
      `  ${name}(params: Params<${JSON.stringify(m.name)}>${optional ? " = {}" : ""}, ${opts}): Result<${JSON.stringify(m.name)}> {`,
      progress
        ? `    const { onProgress, ...call } = options;\n    return this.listening(${JSON.stringify(progress)}, onProgress, () => this.request(${JSON.stringify(m.name)}, params, call));`
        : `    return this.request(${JSON.stringify(m.name)}, params, options);`,
      "  }",
    );
  }
  const long = doc.methods.filter((m) => m["x-long"]).map((m) => JSON.stringify(m.name));
  return [
    "/**",
    " * GENERATED by `npm run gen:contract` from sim-backend/src/robwot_sim/schemas/protocol.openrpc.json — do not",
    " * edit; change the contract (a method's `x-client`, `x-long`, `x-progress`) and regenerate.",
    " */",
    'import type { MethodName, Methods, Notifications } from "@robwot/core/backend-contract";',
    'import type { CallOptions } from "./rpc-connection.js";',
    "",
    "export type Params<M extends MethodName> = Methods[M][\"params\"];",
    "export type Result<M extends MethodName> = Promise<Methods[M][\"result\"]>;",
    "",
    "/** Methods that may last minutes (`x-long`: a motion, a generation, a first load) and that the backend runs",
    " *  off its loop, so its heartbeat keeps answering: no request timeout of their own, the caller's heartbeat",
    " *  bounds them. */",
    `export const LONG_METHODS: ReadonlySet<MethodName> = new Set<MethodName>([${long.join(", ")}]);`,
    "",
    "/** One method per contract method; a client supplies the call and the notification listener. */",
    "export abstract class ContractMethods {",
    "  abstract request<M extends MethodName>(method: M, params: Params<M>, options?: CallOptions): Result<M>;",
    "  protected abstract listening<K extends keyof Notifications, T>(notification: K, listener: ((p: Notifications[K]) => void) | undefined, call: () => Promise<T>): Promise<T>;",
    "",
    ...lines,
    "}",
    "",
  ].join("\n");
}

/** The generated files' contents: `{ ts, md, scene, client }`. */
export async function renderContract() {
  const doc = JSON.parse(await readFile(CONTRACT, "utf8"));
  const intro = await readFile(join(PROSE, "intro.md"), "utf8");
  const example = await readFile(join(PROSE, "example.md"), "utf8");
  const scene = renderSceneSchema(doc, JSON.parse(await readFile(SCENE_SCHEMA, "utf8")));
  return { ts: await renderTypes(doc), md: renderMarkdown(doc, intro, example), scene, client: renderClient(doc) };
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  const { ts, md, scene, client } = await renderContract();
  if (process.argv.includes("--check")) {
    const stale = [];
    if ((await readFile(TS_OUT, "utf8").catch(() => "")) !== ts) stale.push(TS_OUT);
    if ((await readFile(MD_OUT, "utf8").catch(() => "")) !== md) stale.push(MD_OUT);
    if ((await readFile(SCENE_SCHEMA, "utf8").catch(() => "")) !== scene) stale.push(SCENE_SCHEMA);
    if ((await readFile(CLIENT_OUT, "utf8").catch(() => "")) !== client) stale.push(CLIENT_OUT);
    if (stale.length) {
      process.stderr.write(`stale (run npm run gen:contract): ${stale.join(", ")}\n`);
      process.exit(1);
    }
  } else {
    await writeFile(TS_OUT, ts);
    await writeFile(MD_OUT, md);
    await writeFile(SCENE_SCHEMA, scene);
    await writeFile(CLIENT_OUT, client);
    process.stdout.write(`wrote ${TS_OUT}\nwrote ${MD_OUT}\nwrote ${SCENE_SCHEMA}\nwrote ${CLIENT_OUT}\n`);
  }
}
