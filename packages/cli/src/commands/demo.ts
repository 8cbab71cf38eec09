/**
 * `robwot demo` (and `npm start`): generates the bundled demo twin (kuka_iiwa in a bundled scene) into
 * `twins/demo-kuka`, or reuses it when it is complete, then tells where everything is.
 */
import { existsSync, readFileSync } from "node:fs";
import { join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { CliError } from "../errors.js";
import { findExample } from "../examples.js";
import { type GenerateOptions, DEFAULT_BASE_URL } from "./generate-options.js";
import { runGenerate } from "./generate.js";

export const USAGE = `Usage: robwot demo [--out DIR] [--samples N] [--regenerate] [--json]

Generates the demo twin (kuka_iiwa in examples/scenes/table.json) into twins/demo-kuka, or reuses it
when it is complete, and prints where the files are.
`;

const DEMO_FILES = ["td.json", "twin.json", "robot.urdf", "scene.json", "workspace.csv", "workspace.stl", "workspace.json"];

/** The bundled scene: the repository's examples/scenes (relative to this package). */
export function demoScene(): string | undefined {
  const scenes = resolve(import.meta.dirname, "..", "..", "..", "..", "examples", "scenes");
  for (const name of ["table.json", "obstacles-4.json"]) {
    const file = join(scenes, name);
    if (existsSync(file)) return file;
  }
  return undefined;
}

export function twinComplete(dir: string): boolean {
  if (!DEMO_FILES.every((f) => existsSync(join(dir, f)))) return false;
  try {
    JSON.parse(readFileSync(join(dir, "td.json"), "utf8"));
    return true;
  } catch {
    return false;
  }
}

export async function run(argv: string[]): Promise<number> {
  let values;
  try {
    ({ values } = parseArgs({
      args: argv,
      options: { out: { type: "string" }, samples: { type: "string" }, regenerate: { type: "boolean" }, json: { type: "boolean" } },
      strict: true,
    }));
  } catch (err) {
    throw new CliError(`${(err as Error).message} (see robwot demo --help)`);
  }
  const out = resolve(values.out ?? join("twins", "demo-kuka"));
  if (values.regenerate || !twinComplete(out)) {
    const example = findExample("kuka_iiwa");
    if (!example) throw new Error("kuka_iiwa example missing");
    const scene = demoScene();
    const opts: GenerateOptions = {
      example,
      ...(scene ? { scene } : {}),
      samples: values.samples ? Number(values.samples) : 80_000,
      seed: 1,
      out,
      baseUrl: DEFAULT_BASE_URL,
      alpha: "auto",
      packageRoots: {},
      csvJoints: false,
      json: values.json ?? false,
      force: false,
    };
    const code = await runGenerate(opts);
    if (code !== 0) return code;
  } else {
    process.stdout.write(`robwot: reusing the demo twin in ${out} (--regenerate to rebuild it)\n`);
  }
  process.stdout.write(`robwot: demo twin ready: ${join(out, "td.json")}\n`);
  return 0;
}
