/** `robwot openapi`: the OpenAPI 3.0 document of a twin folder's HTTP API (`../openapi.ts`). */
import { existsSync, readFileSync, statSync, writeFileSync } from "node:fs";
import { join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { TWIN_FILES } from "@robwot/core";
import { parseUrl, usageError } from "../args.js";
import { CliError } from "../errors.js";
import { thingOpenApi } from "../openapi.js";

export const USAGE = `Usage: robwot openapi <twin-folder> [options]

Writes the OpenAPI 3.0 document of the twin's HTTP API: the official WoT playground converter
(@thing-description-playground/td_to_openapi) run on the folder's td.json, corrected where the
converter is wrong (complete request and response schemas, the error answers of every status the TD
lists, one server), validated against the OpenAPI 3.0 schema.

Options:
  --out FILE, -o FILE   write the document to FILE (default: standard output)
  --base URL            the servient's URL, as given to robwot serve (e.g. http://127.0.0.1:8080/);
                        default: the base of td.json
`;

const OPTIONS = {
  out: { type: "string", short: "o" },
  base: { type: "string" },
} as const;

function readTd(folder: string): Record<string, unknown> {
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

export async function run(argv: string[]): Promise<number> {
  let parsed;
  try {
    parsed = parseArgs({ args: argv, options: OPTIONS, allowPositionals: true, strict: true });
  } catch (err) {
    throw usageError(err, "openapi", Object.keys(OPTIONS));
  }
  const { values, positionals } = parsed;
  if (positionals.length === 0) throw new CliError("missing twin folder (robwot openapi <twin-folder>)");
  if (positionals.length > 1) throw new CliError(`one twin folder at a time, got ${positionals.length} (robwot openapi <twin-folder>)`);
  const folder = positionals[0] as string;
  const base = parseUrl("base", values.base, ["http", "https"])?.href;
  const td = readTd(folder);
  let doc: unknown;
  try {
    doc = await thingOpenApi(td, base !== undefined ? { base } : {});
  } catch (err) {
    throw new CliError(`${join(resolve(folder), TWIN_FILES.td)}: ${(err as Error).message}`, "E_OPENAPI", 1);
  }
  const text = `${JSON.stringify(doc, null, 2)}\n`;
  if (values.out === undefined) {
    // main exits right after: a pipe takes large writes asynchronously, wait until this one is flushed
    await new Promise<void>((done) => process.stdout.write(text, () => done()));
    return 0;
  }
  const out = resolve(values.out);
  try {
    writeFileSync(out, text);
  } catch (err) {
    throw new CliError(`cannot write ${out}: ${(err as Error).message}`, "E_OUTPUT", 1);
  }
  process.stderr.write(`robwot: OpenAPI document of ${String(td["title"] ?? folder)} written to ${out}\n`);
  return 0;
}
