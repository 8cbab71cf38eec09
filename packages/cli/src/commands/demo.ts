/**
 * `robwot demo` (and `npm start`): generates the bundled demo twin (kuka_iiwa on the bundled table
 * scene) into `twins/demo-kuka`, or reuses it when it is complete, then serves it and prints the TD and
 * viewer URLs.
 */
import { existsSync, readFileSync, statSync } from "node:fs";
import { join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { TWIN_FILES } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { parseInteger, parseRealtime, usageError } from "../args.js";
import { findExample } from "../examples.js";
import { DEFAULT_BASE_URL, DEFAULT_CLEARANCE, type GenerateOptions } from "./generate-options.js";
import { runGenerate } from "./generate.js";
import { parseAllowedHosts, parseCorsOrigins } from "./serve-options.js";
import { serve } from "./serve.js";

export const USAGE = `Usage: robwot demo [options]

Generates the demo twin (kuka_iiwa on examples/scenes/table.json) into twins/demo-kuka, or reuses it
when it is complete, then serves it (like robwot serve) and prints the TD and viewer URLs.

Options:
  --out DIR          twin folder (default twins/demo-kuka)
  --samples N        workspace samples when generating (default ${VALUE_SCHEMAS.Samples.default})
  --regenerate       generate even if the folder is complete
  --port N, --host ADDR, --realtime F   as for robwot serve (default 8080, 127.0.0.1, 1)
  --cors-origin ORIGIN, --allowed-host NAME   as for robwot serve (repeatable)
  --no-serve         only generate (or check) the twin
`;

/** The files of a complete twin folder (`twinComplete`), and those of them that must parse as JSON. */
const REQUIRED_FILES = [TWIN_FILES.td, TWIN_FILES.manifest, TWIN_FILES.urdf, TWIN_FILES.scene, TWIN_FILES.pointCloud, TWIN_FILES.surface, TWIN_FILES.summary, TWIN_FILES.reachability];
const JSON_FILES = [TWIN_FILES.td, TWIN_FILES.manifest, TWIN_FILES.summary];

/** The bundled scene: the repository's examples/scenes, found relative to this package. */
export function demoScene(): string | undefined {
  const scenes = resolve(import.meta.dirname, "..", "..", "..", "..", "examples", "scenes");
  for (const name of ["table.json", "obstacles-4.json"]) {
    const file = join(scenes, name);
    if (existsSync(file)) return file;
  }
  return undefined;
}

/** Every file of Contract 2 present and the JSON ones parse. */
export function twinComplete(dir: string): boolean {
  if (!REQUIRED_FILES.every((f) => existsSync(join(dir, f)))) return false;
  try {
    for (const f of JSON_FILES) JSON.parse(readFileSync(join(dir, f), "utf8"));
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
      options: {
        out: { type: "string" },
        samples: { type: "string" },
        regenerate: { type: "boolean" },
        port: { type: "string" },
        host: { type: "string" },
        realtime: { type: "string" },
        "cors-origin": { type: "string", multiple: true },
        "allowed-host": { type: "string", multiple: true },
        "no-serve": { type: "boolean" },
      },
      strict: true,
    }));
  } catch (err) {
    throw usageError(err, "demo", ["out", "samples", "regenerate", "port", "host", "realtime", "cors-origin", "allowed-host", "no-serve"]);
  }
  const out = resolve(values.out ?? join("twins", "demo-kuka"));
  const { Samples } = VALUE_SCHEMAS;
  const samples = parseInteger("samples", values.samples, Samples.default, Samples.minimum, Samples.maximum);
  const port = parseInteger("port", values.port, 8080, 0, 65535);
  const host = values.host ?? "127.0.0.1";
  const realtime = parseRealtime(values.realtime);
  // every option is checked before the (long) generation
  const corsOrigins = parseCorsOrigins(values["cors-origin"]);
  const allowedHosts = parseAllowedHosts(values["allowed-host"]);
  if (values.regenerate || !twinComplete(out)) {
    const example = findExample("kuka_iiwa");
    if (!example) throw new Error("kuka_iiwa example missing");
    const scene = demoScene();
    const opts: GenerateOptions = {
      example,
      ...(scene ? { scene } : {}),
      samples,
      clearance: DEFAULT_CLEARANCE,
      seed: 1,
      out,
      baseUrl: DEFAULT_BASE_URL,
      alpha: "auto",
      reachVoxel: "auto",
      packageRoots: {},
      couplings: [],
      keepLevel: [],
      csvJoints: false,
      json: false,
      force: false,
    };
    const code = await runGenerate(opts);
    if (code !== 0) return code;
  } else {
    process.stdout.write(`robwot: reusing the demo twin in ${out} (--regenerate to rebuild it)\n`);
    // a calibration written by an earlier session's calibrate action applies to this one too: say so
    const calibration = join(out, TWIN_FILES.calibration);
    if (existsSync(calibration)) {
      process.stdout.write(
        `robwot: note: ${calibration} (written by a calibrate action on ${statSync(calibration).mtime.toISOString()}) applies: ` +
          "the TD's Cartesian frame is the calibrated one (delete the file, or --regenerate, to start uncalibrated)\n",
      );
    }
  }
  if (values["no-serve"]) return 0;
  return serve({ folders: [out], port, host, realtime, corsOrigins, allowedHosts, json: false });
}
