/**
 * `robwot scene from-scan`, end to end: the backend's depth camera over the KUKA on its table (a twin
 * generated for it), the clouds turned into a scene file by the CLI with the twin's robot removed, the
 * scene loaded by `robwot generate --scene` as any hand-written one; a bad cloud refused naming file and
 * reason, with nothing written.
 */
import { existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { launchBackend, type LaunchedBackend } from "@robwot/sim-client";
import { REPO, runCli } from "./cli-run.js";

let work: string;
let backend: LaunchedBackend;
const clouds: string[] = [];
const CAMERAS: [number, number, number][] = [[1.5, 0.2, 1.3], [0.3, 1.6, 1.2], [0.3, -1.6, 1.2]];

beforeAll(async () => {
  work = mkdtempSync(join(tmpdir(), "robwot-scan-"));
  const twin = await runCli(["generate", "kuka_iiwa", "--samples", "3000", "--out", join(work, "twin")]);
  expect(twin.code, twin.stderr).toBe(0);
  backend = await launchBackend();
  const sim = backend.client;
  // the real cell: the table scene with the robot at the twin's home (all joints 0)
  await sim.loadScene({ path: join(REPO, "examples/scenes/table.json") });
  for (const [i, position] of CAMERAS.entries()) {
    const file = join(work, `cam${i}.ply`);
    await sim.captureDepth({ file, position, target: [0.4, 0, 0], noise: 0.0003, dropout: 0.02, seed: i + 1 });
    clouds.push(file);
  }
}, 240_000);

afterAll(async () => {
  await backend?.stop();
  rmSync(work, { recursive: true, force: true });
});

/** A binary STL of a box of size (sx, sy, sz) standing on z = 0, centred on the z axis. */
function boxStl(file: string, [sx, sy, sz]: [number, number, number]): void {
  const c = (i: number): number[] => [(i & 1 ? 0.5 : -0.5) * sx, (i & 2 ? 0.5 : -0.5) * sy, i & 4 ? sz : 0];
  const faces = [[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4], [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]];
  const buf = Buffer.alloc(84 + 50 * faces.length);
  buf.writeUInt32LE(faces.length, 80);
  faces.forEach((f, k) => f.forEach((v, j) => c(v).forEach((x, a) => buf.writeFloatLE(x, 84 + 50 * k + 12 + 12 * j + 4 * a))));
  writeFileSync(file, buf);
}

it("writes a scene of the table, the box and the can without the robot, which generate loads", async () => {
  const out = join(work, "scan.json");
  boxStl(join(work, "crate.stl"), [0.1, 0.1, 0.2]);
  const r = await runCli(["scene", "from-scan", ...clouds, "--twin", join(work, "twin"), "--noise", "0.004", "--out", out, "--model", `crate=${join(work, "crate.stl")}`, "--json"]);
  expect(r.code, r.stderr).toBe(0);
  const result = JSON.parse(r.stdout) as { scan: { points: { robots: number; objects: number }; objects: { name: string; cover: string; model?: { name: string } }[]; supports: { height: number }[] } };
  expect(result.scan.points.robots).toBeGreaterThan(1000);
  // the box and the can (and pieces of the table's edges), never a piece of the robot above the table
  expect(result.scan.objects.length).toBeGreaterThanOrEqual(2);
  expect(result.scan.supports[0]!.height).toBeCloseTo(-0.01, 2);
  // the box is the crate model, placed where it stands; the model's file is copied beside the scene
  const crate = result.scan.objects.filter((o) => o.model?.name === "crate");
  expect(crate).toHaveLength(1);
  const doc = JSON.parse(readFileSync(out, "utf8")) as { version: number; obstacles: { name: string; shape: { type: string; file?: string } }[] };
  expect(doc.version).toBe(1);
  for (const o of doc.obstacles.filter((x) => x.shape.type === "mesh")) {
    // hull files beside the scene, named relative to it
    expect(o.shape.file!.startsWith("scan-meshes/")).toBe(true);
    expect(existsSync(join(work, o.shape.file!))).toBe(true);
  }
  expect(doc.obstacles.some((o) => o.shape.file === `scan-meshes/${crate[0]!.name}-crate.stl`)).toBe(true);
  expect(readdirSync(work).filter((f) => f.startsWith("."))).toEqual([]);
  // the scene file loads as any hand-written scene: a twin generated in it
  const gen = await runCli(["generate", "kuka_iiwa", "--samples", "3000", "--scene", out, "--out", join(work, "scanned-twin")]);
  expect(gen.code, gen.stderr).toBe(0);
  expect(gen.stdout).toMatch(/scene\s+\d+ obstacle\(s\)/);
}, 240_000);

it("refuses a truncated cloud naming the file and the reason, and writes nothing", async () => {
  const bad = join(work, "bad", "cut.ply");
  mkdirSync(join(work, "bad"));
  const whole = readFileSync(clouds[0]!);
  writeFileSync(bad, whole.subarray(0, whole.length - 100));
  const out = join(work, "bad", "scene.json");
  const r = await runCli(["scene", "from-scan", bad, "--out", out]);
  expect(r.code).not.toBe(0);
  expect(r.stderr).toContain("cut.ply");
  expect(r.stderr).toMatch(/E_SCAN|truncated|bytes/i);
  expect(readdirSync(join(work, "bad"))).toEqual(["cut.ply"]);
}, 60_000);

it("refuses bad options before starting anything", async () => {
  const r = await runCli(["scene", "from-scan", clouds[0]!, "--shape", "sphere"]);
  expect(r.code).toBe(2);
  expect(r.stderr).toContain("--shape must be one of tightest, box, hull, voxels");
  const none = await runCli(["scene", "from-scan"]);
  expect(none.code).toBe(2);
  expect(none.stderr).toContain("give at least one point cloud");
});
