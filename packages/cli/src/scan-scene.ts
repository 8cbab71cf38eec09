/**
 * `robwot scene from-scan`: point clouds to a scene file (the backend's `scene.fromScan`). The twin's
 * robot (and its scene's other robots) are loaded at the joints they had when scanned, so that their own
 * points are removed; the scene is checked by loading it as every scene is loaded (`world.loadScene`)
 * before anything is written; the mesh folder and the scene file are then renamed into place.
 */
import { copyFileSync, existsSync, mkdirSync, mkdtempSync, renameSync, rmSync, statSync, writeFileSync } from "node:fs";
import { basename, dirname, extname, join, relative, resolve } from "node:path";
import { loadTwinFolder, robotLoadParams } from "@robwot/servient";
import type { ScanCloud, ScanScene, SceneFromScanParams } from "@robwot/sim-client";
import type { BackendGuard } from "./backend-guard.js";
import { CliError } from "./errors.js";

export interface CloudArg {
  file: string;
  position?: [number, number, number];
  orientation?: [number, number, number, number];
  units: "m" | "mm";
}

export interface FromScanOptions {
  clouds: CloudArg[];
  twin?: string;
  joints?: number[];
  out: string;
  noise: number;
  shape: "tightest" | "box" | "hull" | "voxels";
  voxel: number;
  gap: number;
  occluded: "report" | "block";
  reach: number;
  robotPadding: number;
  /** the user's models (`--model NAME=FILE`) */
  models: { name: string; file: string }[];
}

export type { ScanScene };

/** The folder beside `out` holding its meshes: `<stem>-meshes`. */
export function meshFolder(out: string): string {
  return join(dirname(out), `${basename(out, extname(out))}-meshes`);
}

/** Loads the twin's robot at its scanned joints (given, else its home, else its zeros) and its scene's robots. */
async function loadRobots(backend: BackendGuard, twinDir: string, joints: number[] | undefined): Promise<string[]> {
  const folder = loadTwinFolder(twinDir);
  const m = folder.manifest.robot;
  const model = await backend.sim.loadRobot(robotLoadParams(folder, "scanned"));
  const names = model.controllable;
  if (joints !== undefined && joints.length !== names.length) {
    throw new CliError(`--joints gives ${joints.length} values; the twin's robot has ${names.length} joints (${names.join(", ")})`);
  }
  const q = joints ?? names.map((n) => m.home?.joints[n] ?? 0);
  await backend.sim.setJointPositions({ robot: "scanned", positions: q });
  const others = (folder.scene.robots ?? []) as Record<string, unknown>[];
  if (others.length > 0) {
    const robots = others.map((r) => ({ ...r, urdf: resolve(folder.dir, String(r["urdf"])) }));
    await backend.sim.loadScene({ scene: { version: 1, obstacles: [], robots }, decompose: false });
  }
  return [model.name, ...others.map((r) => String(r["id"]))];
}

/** Each mesh obstacle's file name in the mesh folder: a hull written by the scan keeps its name, a user's
 *  model is copied in as `<obstacle>.<ext>` (a scene file names only files beside it). */
function meshNames(scan: ScanScene, staged: string): Map<string, string> {
  const names = new Map<string, string>();
  for (const o of scan.obstacles) {
    if (o.shape.type !== "mesh") continue;
    const inside = !relative(staged, o.shape.file).startsWith("..");
    names.set(o.name, inside ? basename(o.shape.file) : `${o.name}${extname(o.shape.file)}`);
  }
  return names;
}

/** The scene document of `scan` as written to `out`: mesh files named relative to it. */
function scanDocument(scan: ScanScene, out: string, names: Map<string, string>, description: string): Record<string, unknown> {
  const meshes = relative(dirname(out), meshFolder(out));
  const obstacles = scan.obstacles.map((o) => (o.shape.type !== "mesh" ? o : { ...o, shape: { ...o.shape, file: join(meshes, names.get(o.name)!) } }));
  return { version: 1, name: basename(out, extname(out)), description, obstacles, robots: [] };
}

/** Renames `from` to `to`, replacing what is there only once `from` is complete. */
function swapIn(from: string, to: string): void {
  if (!existsSync(to)) return renameSync(from, to);
  const old = `${to}.old-${process.pid}`;
  renameSync(to, old);
  renameSync(from, to);
  rmSync(old, { recursive: true, force: true });
}

export async function sceneFromScan(o: FromScanOptions, backend: BackendGuard): Promise<{ scan: ScanScene; robots: string[]; meshes: string | null }> {
  const out = resolve(o.out);
  if (!existsSync(dirname(out)) || !statSync(dirname(out)).isDirectory()) throw new CliError(`--out ${o.out}: folder ${dirname(out)} does not exist`);
  const robots = o.twin !== undefined ? await loadRobots(backend, o.twin, o.joints) : [];
  const staged = mkdtempSync(join(dirname(out), `.${basename(out)}-`));
  try {
    const clouds = o.clouds.map((c): ScanCloud => ({ file: resolve(c.file), units: c.units, ...(c.position ? { position: c.position } : {}), ...(c.orientation ? { orientation: c.orientation } : {}) }));
    const scan = await backend.sim.sceneFromScan({
      clouds: [clouds[0]!, ...clouds.slice(1)],
      noise: o.noise, shape: o.shape, voxel: o.voxel, gap: o.gap, occluded: o.occluded, reach: o.reach,
      robotPadding: o.robotPadding, meshDir: staged, models: o.models.map((m) => ({ name: m.name, file: resolve(m.file) })) as SceneFromScanParams["models"],
    });
    const description = `scanned by robwot scene from-scan from ${o.clouds.map((c) => basename(c.file)).join(", ")} (noise ${o.noise} m, ${o.shape} covers${o.occluded === "block" ? ", occluded space blocked" : ""})`;
    const names = meshNames(scan, staged);
    const doc = scanDocument(scan, out, names, description);
    // the same checks as any scene: loaded into an empty world from the staged files
    const check = { ...doc, obstacles: scan.obstacles };
    await backend.sim.resetWorld({});
    await backend.sim.loadScene({ scene: check, decompose: false });
    await backend.sim.resetWorld({});
    const hasMeshes = scan.obstacles.some((x) => x.shape.type === "mesh");
    writeFileSync(join(staged, "scene.json"), `${JSON.stringify(doc, null, 1)}\n`);
    if (hasMeshes) {
      const meshes = join(staged, "meshes");
      mkdirSync(meshes);
      for (const x of scan.obstacles) {
        if (x.shape.type !== "mesh") continue;
        if (names.get(x.name) === basename(x.shape.file) && !relative(staged, x.shape.file).startsWith("..")) renameSync(x.shape.file, join(meshes, basename(x.shape.file)));
        else copyFileSync(x.shape.file, join(meshes, names.get(x.name)!));
      }
      swapIn(meshes, meshFolder(out));
    }
    renameSync(join(staged, "scene.json"), out);
    return { scan, robots, meshes: hasMeshes ? meshFolder(out) : null };
  } finally {
    rmSync(staged, { recursive: true, force: true });
  }
}

/** The lines `robwot scene from-scan` prints. */
export function describeScan(r: { scan: ScanScene; robots: string[]; meshes: string | null }, out: string): string[] {
  const { scan } = r;
  const p = scan.points;
  const lines = [
    `robwot: wrote ${out}${r.meshes ? ` and ${r.meshes}/` : ""} in ${scan.seconds.toFixed(2)} s`,
    `  points     ${p.read} read${p.dropped ? ` (${p.dropped} without return skipped)` : ""}, ${p.robots} the robots'${r.robots.length ? ` (${r.robots.join(", ")})` : ""}, ${p.supports} on supports, ${p.objects} on objects`,
  ];
  for (const s of scan.supports) {
    lines.push(`  ${s.name.padEnd(10)} plane at z = ${s.height.toFixed(3)} m, ${s.points} points${s.lowered > 0 ? `, lowered ${(s.lowered * 1000).toFixed(1)} mm to clear the robot standing on it` : ""}`);
  }
  for (const x of scan.objects) {
    const model = x.model ? `; is a ${x.model.name} (turned ${x.model.yaw.toFixed(2)} rad, points within ${(x.model.p95 * 1000).toFixed(1)} mm of it)` : "";
    lines.push(`  ${x.name.padEnd(10)} ${x.points} points, ${x.cover}${x.parts > 1 ? ` (${x.parts} boxes)` : ""} of ${(x.volume * 1e3).toFixed(2)} l, ${(x.occluded * 1e3).toFixed(1)} l hidden behind it${model}`);
  }
  return lines;
}
