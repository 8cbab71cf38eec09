/**
 * Validation with the official W3C WoT validator `@thing-description-playground/core` (`tdValidator`,
 * CommonJS, loaded lazily through `createRequire`: it pulls in ajv and jsonld). The JSON-LD check needs
 * the network and the Thing Model conformance checks may fetch linked TMs: both are off.
 * Node only (not exported to the browser entry).
 */
import { createRequire } from "node:module";

type Outcome = "passed" | "failed" | "warning" | null;

interface PlaygroundResult {
  report: { json: Outcome; schema: Outcome; defaults: Outcome; jsonld: Outcome; additional: Outcome };
  details: Record<string, Outcome | string>;
  detailComments: Record<string, string>;
}

interface Playground {
  tmValidator(tm: string, log: (message: unknown) => void, options: { checkDefaults?: boolean; checkJsonLd?: boolean }): Promise<PlaygroundResult>;
  tdValidator(
    td: string,
    log: (message: unknown) => void,
    options: { checkDefaults?: boolean; checkJsonLd?: boolean; checkTmConformance?: boolean },
  ): Promise<PlaygroundResult>;
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

let playground: Playground | undefined;

/** Loads the validator's modules (a few hundred ms of CPU), e.g. while a backend starts. Validating a
 * small TD to warm it would cost a compilation more: each validation compiles the TD JSON Schemas again
 * (the validator makes a new ajv instance per call). */
export function loadTdValidator(): void {
  loadPlayground();
}

function loadPlayground(): Playground {
  playground ??= createRequire(import.meta.url)("@thing-description-playground/core") as Playground;
  return playground;
}

export async function validateThingDescription(td: unknown): Promise<TdValidationResult> {
  const text = typeof td === "string" ? td : JSON.stringify(td);
  const log: string[] = [];
  const result = await loadPlayground().tdValidator(text, (m) => log.push(String(m)), {
    checkDefaults: true,
    checkJsonLd: false,
    checkTmConformance: false,
  });
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
  const log: string[] = [];
  const result = await loadPlayground().tmValidator(typeof tm === "string" ? tm : JSON.stringify(tm), (m) => log.push(String(m)), {
    checkDefaults: false,
    checkJsonLd: false,
  });
  const errors: string[] = [];
  if (result.report.json !== "passed") errors.push("not valid JSON");
  if (result.report.schema === "failed") errors.push(`TM JSON Schema: ${log.filter((l) => l.startsWith(">")).map((l) => l.slice(2)).join("; ") || "failed"}`);
  for (const [key, outcome] of Object.entries(result.details)) if (outcome === "failed") errors.push(`${key}: ${result.detailComments[key] ?? key}`);
  return { valid: errors.length === 0, errors, warnings: [], report: result.report };
}
