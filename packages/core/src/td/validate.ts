/**
 * Validation with the official W3C WoT validator `@thing-description-playground/core` (`tdValidator`,
 * CommonJS: it pulls in ajv and jsonld). The JSON-LD check needs the network and the Thing Model
 * conformance checks may fetch linked TMs: both are off.
 *
 * The validator runs on a worker thread of its own, started by the first call (or `loadTdValidator`): its
 * modules load there (a few hundred ms) and each validation compiles the TD JSON Schemas again (the
 * validator makes a new ajv instance per call), both off the caller's event loop, which goes on serving
 * (a generation stops its backend while its TD is checked). The thread keeps the process alive only while
 * a validation is pending; a thread that fails fails the pending validations, and the next call starts
 * another. Node only (not exported to the browser entry).
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

/** The thread's code (CommonJS, evaluated): the playground resolved from this module's folder. */
const THREAD = `
const { parentPort } = require("node:worker_threads");
const playground = require("node:module").createRequire(${JSON.stringify(import.meta.url)})("@thing-description-playground/core");
parentPort.on("message", async ({ id, kind, text }) => {
  const log = [];
  try {
    const result = kind === "td"
      ? await playground.tdValidator(text, (m) => log.push(String(m)), { checkDefaults: true, checkJsonLd: false, checkTmConformance: false })
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
  /** Non-fatal findings (e.g. defaults not spelled out, assertion warnings). */
  warnings: string[];
  report: PlaygroundResult["report"];
}

/** Starts the validator's thread, which loads its modules (a few hundred ms of CPU) there, e.g. while a
 * backend starts. Not a validation: each one compiles the TD JSON Schemas again. */
export function loadTdValidator(): void {
  validatorThread();
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
  if (report.defaults === "warning") warnings.push(`full schema with defaults: ${log.find((l) => l.startsWith(">"))?.slice(2) ?? "warning"}`);
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
