/**
 * A twin's Thing Description: built with `@robwot/core` and validated with the official validator
 * (`robwot generate`), read back from a twin folder and placed at a servient's address (`robwot openapi`,
 * `robwot asyncapi`).
 */
import { existsSync, readFileSync, statSync } from "node:fs";
import { join, resolve } from "node:path";
import {
  type BuildThingDescriptionOptions,
  buildThingDescription,
  canonicalJson,
  compileTdSchemas,
  fnv1a64,
  LIVE_REL,
  loadTdValidator,
  type ThingDescription,
  TWIN_FILES,
  validateThingDescription,
  withAbsoluteForms,
} from "@robwot/core";
import type { RobotModel, WorkspaceSummary } from "@robwot/sim-client";
import { CliError } from "./errors.js";

export interface BuiltTd {
  td: ThingDescription;
  /** Errors of the official validator (empty when valid). */
  validate(): Promise<string[]>;
}

export function buildTd(model: RobotModel, summary: WorkspaceSummary, scene: unknown, baseUrl: string, tool?: BuildThingDescriptionOptions["tool"], gripper?: BuildThingDescriptionOptions["gripper"]): BuiltTd {
  const td = buildThingDescription({ model, summary, baseUrl, sceneId: fnv1a64(canonicalJson(scene)), srdf: model.srdf !== undefined, ...(tool ? { tool } : {}), ...(gripper ? { gripper } : {}) });
  return {
    td,
    async validate() {
      const result = await validateThingDescription(td);
      return result.valid ? [] : result.errors.length > 0 ? result.errors : ["rejected by the validator"];
    },
  };
}

/**
 * Starts the official TD validator's thread, which loads its modules while the backend's Python starts up.
 * Never fails.
 */
export async function warmTdValidator(): Promise<void> {
  await Promise.resolve().then(loadTdValidator).catch(() => undefined);
}

/** Has the validator compile the TD JSON Schema now (a generation: when its labelling workers are done).
 * Never fails: a validation after it compiles what it needs. */
export function compileTdSchemasNow(): void {
  try {
    compileTdSchemas();
  } catch {
    // the validation starts the thread again and reports why it cannot
  }
}

export function tdErrorsMessage(errors: string[]): string {
  return errors.slice(0, 5).join("; ") + (errors.length > 5 ? ` (and ${errors.length - 5} more)` : "");
}

/** The TD of a twin folder (td.json), or a CliError naming the folder or file. */
export function readTwinTd(folder: string): Record<string, unknown> {
  const dir = resolve(folder);
  if (!existsSync(dir) || !statSync(dir).isDirectory()) throw new CliError(`twin folder not found: ${dir}`, "E_TWIN_FOLDER", 1);
  const file = join(dir, TWIN_FILES.td);
  if (!existsSync(file)) throw new CliError(`${dir} is not a twin folder: no ${TWIN_FILES.td} (create one with robwot generate)`, "E_TWIN_FOLDER", 1);
  let td: unknown;
  try {
    td = JSON.parse(readFileSync(file, "utf8"));
  } catch (err) {
    throw new CliError(`${file} is not valid JSON: ${(err as Error).message}`, "E_TD", 1);
  }
  if (typeof td !== "object" || td === null || Array.isArray(td)) throw new CliError(`${file} is not a Thing Description (not a JSON object)`, "E_TD", 1);
  return td as Record<string, unknown>;
}

/**
 * `td` as `robwot serve` at `base` (the servient's URL) serves it: forms absolute at `<base>/<slug>/` (the
 * slug of the TD's base; `base` naming the Thing itself, `http://host/<slug>/`, is taken as it is) and the
 * `/live` link at the servient's host. A copy; throws when the TD has no base to take the slug from.
 */
export function placeTd(tdIn: Record<string, unknown>, base: string): Record<string, unknown> {
  const td = structuredClone(tdIn);
  const slug = typeof td["base"] === "string" ? new URL(td["base"]).pathname.split("/").filter(Boolean).pop() : undefined;
  if (slug === undefined) throw new Error("the TD has no base to take the Thing's path from");
  const at = base.endsWith("/") ? base : `${base}/`;
  const named = new URL(at).pathname.split("/").filter(Boolean).pop() === slug;
  withAbsoluteForms(td, named ? new URL(at).href : new URL(`${slug}/`, at).href);
  const origin = new URL(at);
  for (const l of Array.isArray(td["links"]) ? (td["links"] as Record<string, unknown>[]) : []) {
    if (l["rel"] === LIVE_REL) l["href"] = `${origin.protocol === "https:" ? "wss:" : "ws:"}//${origin.host}/live`;
  }
  return td;
}
