/** The commands that write a document made from a twin folder's TD (`robwot openapi`, `robwot asyncapi`). */
import { writeFileSync } from "node:fs";
import { join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { TWIN_FILES } from "@robwot/core";
import { parseUrl, usageError } from "../args.js";
import { CliError } from "../errors.js";
import { readTwinTd } from "../td.js";

/** The options every such command takes, as its usage states them. */
export const DOCUMENT_OPTIONS_HELP = `Options:
  --out FILE, -o FILE   write the document to FILE (default: standard output)
  --base URL            the servient's URL, as given to robwot serve (e.g. http://127.0.0.1:8080/);
                        default: the base of td.json
`;

const OPTIONS = {
  out: { type: "string", short: "o" },
  base: { type: "string" },
} as const;

/**
 * Parses `<twin-folder> [--out FILE] [--base URL]`, makes the document with `make` from the folder's TD
 * (a failure is a CliError with `code`, naming td.json) and writes it as JSON to `--out` or stdout.
 */
export async function writeTwinDocument(
  argv: string[],
  command: string,
  code: string,
  what: string,
  make: (td: Record<string, unknown>, base: string | undefined) => Promise<unknown>,
): Promise<number> {
  let parsed;
  try {
    parsed = parseArgs({ args: argv, options: OPTIONS, allowPositionals: true, strict: true });
  } catch (err) {
    throw usageError(err, command, Object.keys(OPTIONS));
  }
  const { values, positionals } = parsed;
  if (positionals.length === 0) throw new CliError(`missing twin folder (robwot ${command} <twin-folder>)`);
  if (positionals.length > 1) throw new CliError(`one twin folder at a time, got ${positionals.length} (robwot ${command} <twin-folder>)`);
  const folder = positionals[0] as string;
  const base = parseUrl("base", values.base, ["http", "https"])?.href;
  const td = readTwinTd(folder);
  let doc: unknown;
  try {
    doc = await make(td, base);
  } catch (err) {
    throw new CliError(`${join(resolve(folder), TWIN_FILES.td)}: ${(err as Error).message}`, code, 1);
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
  process.stderr.write(`robwot: ${what} of ${String(td["title"] ?? folder)} written to ${out}\n`);
  return 0;
}
