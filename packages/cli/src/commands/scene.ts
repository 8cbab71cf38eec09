/** `robwot scene from-scan CLOUD...`: a conservative scene file from point clouds (`../scan-scene.ts`). */
import { existsSync, statSync } from "node:fs";
import { parseArgs } from "node:util";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { parseNumber, usageError } from "../args.js";
import { BackendGuard } from "../backend-guard.js";
import { CliError } from "../errors.js";
import { onCleanup } from "../lifecycle.js";
import { describeScan, sceneFromScan, type CloudArg, type FromScanOptions } from "../scan-scene.js";

export const USAGE = `Usage: robwot scene from-scan CLOUD... [options]

Builds a scene file from point clouds (PLY, PCD or XYZ; ascii or binary): the support planes found
(floor, table tops) as boxes, the other points clustered into objects, each covered by obstacles. Every
scanned point, grown by --noise in every direction, lies inside the obstacles written, so a twin built
with the scene never calls free what the scan shows blocked. The scene loads as any hand-written one
(robwot generate ROBOT --scene FILE). Units: metres, radians.

Options:
  --pose X,Y,Z[,QX,QY,QZ,QW]  the sensor's pose in the world for the cloud at the same place in the list
                         (repeat per cloud; default: the file's own viewpoint (PCD VIEWPOINT), else the
                         cloud is in world coordinates)
  --units m|mm           the clouds' unit (default m)
  --twin FOLDER          remove this twin's robot (and its scene's robots) from the clouds
  --joints Q1,Q2,...     the twin robot's joints when scanned (default its home, else zeros)
  --out FILE             the scene file (default scene.json); hull meshes go to FILE's stem + "-meshes/"
  --noise M              the sensor's noise: every point grown by it (default 0.005)
  --shape tightest|box|hull|voxels   each object's cover (default tightest: the least volume)
  --voxel M              voxel side of voxel covers (default 0.02)
  --gap M                points closer than this belong to one object (default 0.03)
  --occluded report|block   space hidden behind objects: reported, or also blocked (default report)
  --reach M              how far a shadow reaches where its rays meet no support (default 2)
  --robot-padding M      points this close to a robot are its own (default 0.01)
  --model NAME=FILE      a mesh (STL, OBJ, DAE; metres, Z up, resting on its lowest point) of a thing that
                         may stand in the cell: an object it fits (turned about Z, on its support) is
                         placed as that model too, adding what the sensor could not see; repeatable
  --backend ws://HOST:PORT   use a running backend instead of starting one
  --json                 print the result as JSON
`;

const OPTIONS = {
  pose: { type: "string", multiple: true },
  units: { type: "string" },
  twin: { type: "string" },
  joints: { type: "string" },
  out: { type: "string" },
  noise: { type: "string" },
  shape: { type: "string" },
  voxel: { type: "string" },
  gap: { type: "string" },
  occluded: { type: "string" },
  reach: { type: "string" },
  "robot-padding": { type: "string" },
  model: { type: "string", multiple: true },
  backend: { type: "string" },
  json: { type: "boolean" },
} as const;

function numbers(option: string, text: string, counts: number[]): number[] {
  const values = text.split(",").map((v) => Number(v.trim()));
  if (!counts.includes(values.length) || values.some((v) => !Number.isFinite(v)) || text.trim() === "") {
    throw new CliError(`--${option} must be ${counts.join(" or ")} comma-separated numbers, got "${text}"`);
  }
  return values;
}

function oneOf<T extends string>(option: string, value: string | undefined, allowed: readonly T[], fallback: T): T {
  if (value === undefined) return fallback;
  if (!(allowed as readonly string[]).includes(value)) throw new CliError(`--${option} must be one of ${allowed.join(", ")}, got "${value}"`);
  return value as T;
}

function clouds(files: string[], poses: string[], units: "m" | "mm"): CloudArg[] {
  if (files.length === 0) throw new CliError("give at least one point cloud (robwot scene from-scan CLOUD...)");
  if (poses.length > files.length) throw new CliError(`${poses.length} --pose options for ${files.length} cloud(s): give at most one per cloud, in the clouds' order`);
  return files.map((file, i) => {
    if (!existsSync(file) || !statSync(file).isFile()) throw new CliError(`point cloud not found: ${file}`);
    const pose = poses[i] === undefined ? undefined : numbers("pose", poses[i], [3, 7]);
    return {
      file,
      units,
      ...(pose ? { position: pose.slice(0, 3) as [number, number, number] } : {}),
      ...(pose && pose.length === 7 ? { orientation: pose.slice(3) as [number, number, number, number] } : {}),
    };
  });
}

/** `--model NAME=FILE`: a model's name (a scene name) and its mesh file, which must exist. */
function parseModel(text: string): { name: string; file: string } {
  const eq = text.indexOf("=");
  const name = eq > 0 ? text.slice(0, eq) : "";
  const file = text.slice(eq + 1);
  if (!/^[A-Za-z0-9_.-]{1,64}$/.test(name) || file === "") throw new CliError(`--model must look like NAME=FILE (e.g. crate=crate.stl), got "${text}"`);
  if (!existsSync(file) || !statSync(file).isFile()) throw new CliError(`--model ${name}: mesh file not found: ${file}`);
  return { name, file };
}

function models(values: string[]): { name: string; file: string }[] {
  if (values.length > 16) throw new CliError(`at most 16 --model options, got ${values.length}`);
  return values.map(parseModel);
}

export function parseFromScanArgs(argv: string[]): FromScanOptions & { backend?: string; json: boolean } {
  let parsed;
  try {
    parsed = parseArgs({ args: argv, options: OPTIONS, allowPositionals: true, strict: true });
  } catch (err) {
    throw usageError(err, "scene from-scan", Object.keys(OPTIONS));
  }
  const { values: v, positionals } = parsed;
  const noise = VALUE_SCHEMAS.ScanNoise;
  return {
    clouds: clouds(positionals, v.pose ?? [], oneOf("units", v.units, ["m", "mm"], "m")),
    ...(v.twin !== undefined ? { twin: v.twin } : {}),
    ...(v.joints !== undefined ? { joints: v.joints.split(",").map((x) => parseNumber("joints", x, 0, -1e3, 1e3)) } : {}),
    out: v.out ?? "scene.json",
    noise: parseNumber("noise", v.noise, 0.005, noise.minimum, noise.maximum),
    shape: oneOf("shape", v.shape, ["tightest", "box", "hull", "voxels"], "tightest"),
    voxel: parseNumber("voxel", v.voxel, 0.02, 0.005, 0.5),
    gap: parseNumber("gap", v.gap, 0.03, 0.002, 0.5),
    occluded: oneOf("occluded", v.occluded, ["report", "block"], "report"),
    reach: parseNumber("reach", v.reach, 2, 0.01, 20),
    robotPadding: parseNumber("robot-padding", v["robot-padding"], 0.01, 0, 0.1),
    models: models(v.model ?? []),
    ...(v.backend !== undefined ? { backend: v.backend } : {}),
    json: v.json ?? false,
  };
}

export async function run(argv: string[]): Promise<number> {
  const [sub, ...rest] = argv;
  if (sub !== "from-scan") throw new CliError(`unknown scene command "${sub ?? ""}" (valid: from-scan; see robwot scene --help)`);
  const opts = parseFromScanArgs(rest);
  const backend = await BackendGuard.open(opts.backend);
  const drop = onCleanup(() => backend.close());
  try {
    const result = await sceneFromScan(opts, backend).catch(async (err: unknown) => {
      throw await backend.explain(err);
    });
    if (opts.json) process.stdout.write(`${JSON.stringify({ ok: true, out: opts.out, ...result }, null, 2)}\n`);
    else process.stdout.write(`${describeScan(result, opts.out).join("\n")}\n`);
    return 0;
  } finally {
    drop();
    await backend.close();
  }
}
