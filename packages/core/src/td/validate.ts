/**
 * Validation with the official W3C WoT validator `@thing-description-playground/core` (`tdValidator`,
 * CommonJS: it pulls in ajv and jsonld). The JSON-LD check needs the network and the Thing Model
 * conformance checks may fetch linked TMs: both are off. So is the check against the schema with defaults
 * spelled out, which can only warn (a TD may leave defaults out) and would compile a second schema.
 *
 * The validator runs on a worker thread of its own, started by the first call (or `loadTdValidator`), off
 * the caller's event loop, which goes on serving (a generation stops its backend while its TD is checked).
 * Its modules load there, and there the TD JSON Schemas are compiled once: the playground makes a new
 * ajv instance per validation, which would compile them again each time (most of a validation's CPU), so
 * the ajv class it requires is replaced by one whose instances share compiled schemas (see THREAD). The
 * thread keeps the process alive only while a validation is pending; a thread that fails fails the pending
 * validations, and the next call starts another. Node only (not exported to the browser entry).
 */
import { Worker } from "node:worker_threads";

type Outcome = "passed" | "failed" | "warning" | null;

interface PlaygroundResult {
  report: { json: Outcome; schema: Outcome; defaults: Outcome; jsonld: Outcome; additional: Outcome };
  details: Record<string, Outcome | string>;
  detailComments: Record<string, string>;
}

type Kind = "td" | "tm";

interface Answer {
  id: number;
  result?: PlaygroundResult;
  log?: string[];
  error?: string;
}

/** A minimal valid TD: validating it compiles the schema every TD is checked against (`compileTdSchemas`). */
const WARM_TD = {
  "@context": "https://www.w3.org/2022/wot/td/v1.1",
  title: "warm-up",
  securityDefinitions: { nosec_sc: { scheme: "nosec" } },
  security: "nosec_sc",
  properties: { p: { type: "number", forms: [{ href: "http://127.0.0.1/p" }] } },
};

/**
 * The thread's code (CommonJS, evaluated): the playground resolved from this module's folder. Before the
 * playground loads, two of the modules it requires are given to it otherwise:
 * - ajv: a subclass whose instances share one compiled-schema cache (ajv's own cache, keyed by the schema
 *   object) per set of options. Sound because every instance the playground makes (one per tdValidator and
 *   tmValidator call) is made alike: the same options, the formats of ajv-formats and ajv-formats-draft2019,
 *   no other keywords; ajv copies a validation's errors to the instance that asked. Validations run one at
 *   a time (each is synchronous up to its verdict).
 * - jsonld (most of the playground's load time), loaded at its first use: only the JSON-LD check, which is
 *   off, uses it.
 */
const THREAD = `
const { parentPort } = require("node:worker_threads");
const { createRequire, Module } = require("node:module");
const playgroundPath = createRequire(${JSON.stringify(import.meta.url)}).resolve("@thing-description-playground/core");
const requirePlayground = createRequire(playgroundPath);
const Ajv = requirePlayground("ajv");
const caches = new Map();
let making = "{}";
class SharedCompilations extends Ajv {
  constructor(opts = {}) {
    making = JSON.stringify(opts);
    super(opts);
    this.sharedCacheKey = making;
  }
  get _cache() {
    const key = this.sharedCacheKey ?? making;
    let cache = caches.get(key);
    if (cache === undefined) caches.set(key, (cache = new Map()));
    return cache;
  }
  set _cache(_ownMap) {}
}
requirePlayground.cache[requirePlayground.resolve("ajv")].exports = SharedCompilations;
const jsonldPath = requirePlayground.resolve("jsonld");
const deferred = new Module(jsonldPath);
deferred.filename = jsonldPath;
deferred.loaded = true;
let jsonld;
deferred.exports = new Proxy({}, {
  get(_none, key) {
    if (jsonld === undefined) {
      delete requirePlayground.cache[jsonldPath];
      jsonld = requirePlayground(jsonldPath);
    }
    return jsonld[key];
  },
});
requirePlayground.cache[jsonldPath] = deferred;
const playground = requirePlayground(playgroundPath);
const TD_CHECKS = { checkDefaults: false, checkJsonLd: false, checkTmConformance: false };
parentPort.on("message", async ({ id, kind, text }) => {
  if (kind === "warm") {
    await playground.tdValidator(${JSON.stringify(JSON.stringify(WARM_TD))}, () => undefined, TD_CHECKS).catch(() => undefined);
    return;
  }
  const log = [];
  try {
    const result = kind === "td"
      ? await playground.tdValidator(text, (m) => log.push(String(m)), TD_CHECKS)
      : await playground.tmValidator(text, (m) => log.push(String(m)), { checkDefaults: false, checkJsonLd: false });
    parentPort.postMessage({ id, result, log });
  } catch (err) {
    parentPort.postMessage({ id, error: String((err && err.stack) || err) });
  }
});
`;

let thread: Worker | undefined;
const pending = new Map<number, { resolve: (a: Answer) => void; reject: (err: Error) => void }>();
let nextId = 0;

function validatorThread(): Worker {
  if (thread !== undefined) return thread;
  const t = new Worker(THREAD, { eval: true });
  t.unref();
  const fail = (err: Error): void => {
    if (thread === t) thread = undefined;
    for (const p of pending.values()) p.reject(err);
    pending.clear();
  };
  t.on("message", (a: Answer) => {
    const p = pending.get(a.id);
    if (p === undefined) return;
    pending.delete(a.id);
    if (pending.size === 0) t.unref();
    if (a.error !== undefined) p.reject(new Error(`the TD validator failed: ${a.error}`));
    else p.resolve(a);
  });
  t.on("error", (err) => fail(err));
  t.on("exit", (code) => fail(new Error(`the TD validator's thread exited with code ${code}`)));
  thread = t;
  return t;
}

function validate(kind: Kind, text: string): Promise<{ result: PlaygroundResult; log: string[] }> {
  const t = validatorThread();
  const id = nextId++;
  return new Promise((resolve, reject) => {
    pending.set(id, { resolve: (a) => resolve({ result: a.result as PlaygroundResult, log: a.log ?? [] }), reject });
    t.ref();
    t.postMessage({ id, kind, text });
  });
}

export interface TdValidationResult {
  /** JSON, TD 1.1 JSON Schema and the additional assertions passed (warnings allowed). */
  valid: boolean;
  /** Why it is not valid: schema errors and failed assertions. */
  errors: string[];
  /** Non-fatal findings of the additional assertions. */
  warnings: string[];
  report: PlaygroundResult["report"];
}

/** Starts the validator's thread, which loads its modules there (a few hundred ms of CPU), e.g. while a
 * backend starts. */
export function loadTdValidator(): void {
  validatorThread();
}

/** Has the validator's thread (started if need be) compile the TD JSON Schema now, e.g. while a core is idle,
 * rather than at the next validation. */
export function compileTdSchemas(): void {
  validatorThread().postMessage({ kind: "warm" });
}

export async function validateThingDescription(td: unknown): Promise<TdValidationResult> {
  const { result, log } = await validate("td", typeof td === "string" ? td : JSON.stringify(td));
  const errors: string[] = [];
  const warnings: string[] = [];
  const { report, details, detailComments } = result;
  if (report.json !== "passed") errors.push("not valid JSON");
  if (report.schema === "failed") {
    errors.push(`TD 1.1 JSON Schema: ${log.filter((l) => l.startsWith(">")).map((l) => l.slice(2)).join("; ") || "failed"}`);
  }
  for (const [key, outcome] of Object.entries(details)) {
    const why = detailComments[key] ?? key;
    if (outcome === "failed") errors.push(`${key}: ${why}`);
    else if (outcome === "warning") warnings.push(`${key}: ${why}`);
  }
  const valid = report.json === "passed" && report.schema === "passed" && report.additional !== "failed";
  return { valid, errors, warnings, report };
}

/** A Thing Model against the official TM JSON Schema and assertions (JSON-LD off). */
export async function validateThingModel(tm: unknown): Promise<TdValidationResult> {
  const { result, log } = await validate("tm", typeof tm === "string" ? tm : JSON.stringify(tm));
  const errors: string[] = [];
  if (result.report.json !== "passed") errors.push("not valid JSON");
  if (result.report.schema === "failed") errors.push(`TM JSON Schema: ${log.filter((l) => l.startsWith(">")).map((l) => l.slice(2)).join("; ") || "failed"}`);
  for (const [key, outcome] of Object.entries(result.details)) if (outcome === "failed") errors.push(`${key}: ${result.detailComments[key] ?? key}`);
  return { valid: errors.length === 0, errors, warnings: [], report: result.report };
}
