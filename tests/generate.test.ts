/**
 * End to end: `robwot generate` as a real child process with the real Python backend, checking the twin
 * folder it writes (Contract 2) and the Thing Description (Contract 3) with the official validator.
 */
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync, mkdirSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { runCli, TINY_URDF } from "./cli-run.js";
import { checkBinaryStl, officialTdValidation, readCsv } from "./twin-files.js";

const SAMPLES = 3000;
let work: string;


beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-generate-"));
  writeFileSync(join(work, "tiny.urdf"), TINY_URDF);
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

interface Summary {
  samples: number;
  collisionFree: number;
  bounds: { min: number[]; max: number[] };
  reachBounds: { min: number[]; max: number[] };
  method: string;
  volume: number;
  seed: number;
}

async function generate(robot: string, out: string, extra: string[] = []): Promise<Record<string, unknown>> {
  const r = await runCli(["generate", robot, "--samples", String(SAMPLES), "--out", out, "--json", ...extra]);
  expect(r.stderr, r.stderr).not.toMatch(/unknown format/);
  expect(r.code, `exit ${r.code}\n${r.stderr}`).toBe(0);
  return JSON.parse(r.stdout) as Record<string, unknown>;
}

const json = (file: string): Record<string, any> => JSON.parse(readFileSync(file, "utf8")) as Record<string, any>;

describe.each([
  ["kuka_iiwa", "kuka_iiwa", 7, true],
  // 7 arm joints + panda_finger_joint1 (panda_finger_joint2 mimics it)
  ["franka_panda", "franka_panda", 8, true],
  ["xarm6", "xarm6", 6, true],
  ["tiny URDF", "TINY", 3, false],
])("robwot generate %s", (_label, robotArg, dof, hasMeshes) => {
  let out: string;
  let printed: Record<string, unknown>;
  beforeAll(async () => {
    out = join(work, `twin-${robotArg}`);
    printed = await generate(robotArg === "TINY" ? join(work, "tiny.urdf") : robotArg, out);
  });

  it("writes the complete twin folder and nothing else next to it", () => {
    for (const f of ["td.json", "twin.json", "robot.urdf", "scene.json", "workspace.csv", "workspace.stl", "workspace.json", "reachability.csv"]) {
      expect(existsSync(join(out, f)), f).toBe(true);
    }
    expect(readdirSync(work).filter((n) => n.includes(".tmp-") || n.includes(".old-"))).toEqual([]);
    expect(printed["ok"]).toBe(true);
  });

  it("writes a labelled point cloud with one row per sample", () => {
    const csv = readCsv(join(out, "workspace.csv"));
    expect(csv.header).toEqual(["x", "y", "z", "collision_free"]);
    expect(csv.rows.length).toBe(SAMPLES);
    for (const row of csv.rows) {
      expect(row.length).toBe(4);
      expect(row.slice(0, 3).every(Number.isFinite)).toBe(true);
      expect([0, 1]).toContain(row[3]);
    }
    const summary = json(join(out, "workspace.json")) as Summary;
    const free = csv.rows.filter((r) => r[3] === 1);
    expect(summary.samples).toBe(SAMPLES);
    expect(summary.collisionFree).toBe(free.length);
    expect(free.length).toBeGreaterThan(SAMPLES * 0.2);
    for (let k = 0; k < 3; k++) {
      expect(Math.min(...free.map((r) => r[k]!))).toBeCloseTo(summary.bounds.min[k]!, 4);
      expect(Math.max(...free.map((r) => r[k]!))).toBeCloseTo(summary.bounds.max[k]!, 4);
    }
  });

  it("writes a closed, outward-oriented binary STL whose volume matches workspace.json", () => {
    const stl = checkBinaryStl(join(out, "workspace.stl"));
    const summary = json(join(out, "workspace.json")) as Summary;
    expect(stl.triangles).toBeGreaterThan(10);
    expect(stl.closed).toBe(true);
    expect(stl.consistent).toBe(true);
    expect(stl.signedVolume).toBeGreaterThan(0);
    expect(stl.normalsAgree).toBeGreaterThan(0.99);
    expect(stl.signedVolume).toBeCloseTo(summary.volume, 2);
  });

  it("writes a Thing Description that passes the official validator, with the twin's limits and links", async () => {
    const text = readFileSync(join(out, "td.json"), "utf8");
    const { result, log } = await officialTdValidation(text);
    expect(result.report.json).toBe("passed");
    expect(result.report.schema, log.join("\n")).toBe("passed");
    expect(result.report.additional, log.join("\n")).not.toBe("failed");
    const td = JSON.parse(text) as Record<string, any>;
    expect(td["base"]).toMatch(/^http:\/\/localhost:8080\/.+\/$/);
    const joints = td["properties"]["getJointPosition"]["properties"] as Record<string, { minimum: number; maximum: number }>;
    expect(Object.keys(joints).length).toBe(dof);
    for (const j of Object.values(joints)) expect(j.maximum).toBeGreaterThan(j.minimum);
    const summary = json(join(out, "workspace.json")) as Summary;
    const cart = td["actions"]["moveToCartesianPosition"]["input"]["properties"];
    // Cartesian targets are bounded by the reach box, which holds every sample and a little more
    expect(cart.x.minimum).toBeCloseTo(summary.reachBounds.min[0]!, 6);
    expect(cart.z.maximum).toBeCloseTo(summary.reachBounds.max[2]!, 6);
    for (const k of [0, 1, 2]) {
      expect(summary.reachBounds.min[k]!).toBeLessThanOrEqual(summary.bounds.min[k]!);
      expect(summary.reachBounds.max[k]!).toBeGreaterThanOrEqual(summary.bounds.max[k]!);
    }
    for (const name of ["moveToJointPosition", "moveToCartesianPosition"]) expect(td["actions"][name]).toBeDefined();
    const links = td["links"] as { rel: string; href: string; type: string }[];
    const byRel = Object.fromEntries(links.map((l) => [l.rel, l]));
    expect(byRel["model"]).toMatchObject({ href: "robot.urdf", type: "application/urdf+xml" });
    expect(byRel["workspace-pointcloud"]).toMatchObject({ href: "workspace.csv", type: "text/csv" });
    expect(byRel["workspace"]).toMatchObject({ href: "workspace.stl", type: "model/stl" });
    expect(byRel["type"]).toMatchObject({ href: "robot-arm.tm.json", type: "application/tm+json" });
    expect(json(join(out, "robot-arm.tm.json"))).toMatchObject({ "@type": "tm:ThingModel" });
    for (const l of links) if (l.rel !== "robwot:live") expect(existsSync(join(out, l.href)), l.href).toBe(true);
  });

  it("writes twin.json and a self-contained URDF", () => {
    const twin = json(join(out, "twin.json"));
    expect(twin).toMatchObject({ version: 1, scene: "scene.json", robot: { urdf: "robot.urdf" } });
    expect(typeof twin["robot"]["eeLink"]).toBe("string");
    expect(json(join(out, "scene.json"))["obstacles"]).toEqual([]);
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    const meshes = [...urdf.matchAll(/<mesh\b[^>]*\bfilename="([^"]+)"/g)].map((m) => m[1]!);
    expect(meshes.length > 0).toBe(hasMeshes);
    for (const m of meshes) {
      expect(m).not.toMatch(/^(\/|package:\/\/|file:)/);
      expect(existsSync(join(out, m)), m).toBe(true);
    }
  });
});

describe("determinism, obstacles, replacement, placement", () => {
  const rowsOf = (dir: string): number[][] => readCsv(join(dir, "workspace.csv")).rows;

  it("same seed gives an identical workspace.csv", async () => {
    const a = join(work, "seed-a");
    const b = join(work, "seed-b");
    await generate("kuka_iiwa", a, ["--seed", "7"]);
    await generate("kuka_iiwa", b, ["--seed", "7"]);
    expect(readFileSync(join(a, "workspace.csv")).equals(readFileSync(join(b, "workspace.csv")))).toBe(true);
    expect(readFileSync(join(a, "workspace.stl")).equals(readFileSync(join(b, "workspace.stl")))).toBe(true);
  });

  it("different seeds give other samples but bounds within a few cm", async () => {
    const runs = [join(work, "seed-c"), join(work, "seed-d")];
    for (const [i, out] of runs.entries()) {
      const r = await runCli(["generate", "kuka_iiwa", "--out", out, "--seed", String(8 + i), "--samples", "10000"]);
      expect(r.code, r.stderr).toBe(0);
    }
    const [c, d] = runs.map((dir) => json(join(dir, "workspace.json")) as Summary) as [Summary, Summary];
    expect(readFileSync(join(runs[0]!, "workspace.csv")).equals(readFileSync(join(runs[1]!, "workspace.csv")))).toBe(false);
    for (let k = 0; k < 3; k++) {
      expect(Math.abs(c.bounds.min[k]! - d.bounds.min[k]!)).toBeLessThan(0.05);
      expect(Math.abs(c.bounds.max[k]! - d.bounds.max[k]!)).toBeLessThan(0.05);
    }
  });

  it("a box in the workspace removes exactly collision-free points, and those near the box", async () => {
    const box = { name: "block", shape: { type: "box", size: [0.4, 0.4, 0.4] }, position: [0.5, 0, 0.5] };
    const sceneFile = join(work, "box-scene.json");
    writeFileSync(sceneFile, JSON.stringify({ version: 1, obstacles: [box] }));
    const free = join(work, "no-box");
    const boxed = join(work, "with-box");
    await generate("kuka_iiwa", free, ["--seed", "3"]);
    await generate("kuka_iiwa", boxed, ["--seed", "3", "--scene", sceneFile]);
    const a = rowsOf(free);
    const b = rowsOf(boxed);
    expect(b.length).toBe(a.length);
    let removed = 0;
    let freeInsideBox = 0;
    for (let i = 0; i < a.length; i++) {
      const ra = a[i]!;
      const rb = b[i]!;
      expect(rb.slice(0, 3)).toEqual(ra.slice(0, 3));
      expect(rb[3]!).toBeLessThanOrEqual(ra[3]!);
      if (ra[3] === 1 && rb[3] === 0) removed++;
      const inside = [0, 1, 2].every((k) => Math.abs(rb[k]! - (box.position[k] as number)) < 0.2);
      if (inside && rb[3] === 1) freeInsideBox++;
    }
    expect(removed).toBeGreaterThan(SAMPLES * 0.05);
    expect(freeInsideBox).toBe(0);
    const scene = json(join(boxed, "scene.json"));
    expect(scene["obstacles"]).toHaveLength(1);
    expect(scene["obstacles"][0]).toMatchObject({ name: "block", shape: { type: "box" } });
    expect((json(join(boxed, "workspace.json")) as Summary).collisionFree).toBeLessThan((json(join(free, "workspace.json")) as Summary).collisionFree);
  });

  it("regenerating replaces an existing twin only once the new one is complete", async () => {
    const out = join(work, "replace-me");
    mkdirSync(out);
    writeFileSync(join(out, "twin.json"), "{}");
    writeFileSync(join(out, "stale.txt"), "old");
    await generate("xarm6", out);
    expect(existsSync(join(out, "stale.txt"))).toBe(false);
    expect(existsSync(join(out, "td.json"))).toBe(true);
    expect(readdirSync(work).filter((n) => n.includes(".tmp-") || n.includes(".old-"))).toEqual([]);
  });

  it("a twin of another robot is not replaced without --force; the same robot's is", async () => {
    const out = join(work, "someone-elses");
    await generate(join(work, "tiny.urdf"), out);
    const before = readFileSync(join(out, "td.json"), "utf8");
    const r = await runCli(["generate", "ur3", "--samples", String(SAMPLES), "--out", out]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/robwot: error: output .*someone-elses holds the twin of robot "\w+", not "ur3": refusing to replace it \(use --force, or another --out\)/);
    expect(readFileSync(join(out, "td.json"), "utf8")).toBe(before);
    expect(readdirSync(work).filter((n) => n.includes(".tmp-"))).toEqual([]);
    await generate("ur3", out, ["--force"]);
    expect(json(join(out, "twin.json"))["robot"]["name"]).toBe("ur3");
  });

  it("a scene that places the generated robot sets its base pose; --csv-joints adds joint columns", async () => {
    const sceneFile = join(work, "placed.json");
    writeFileSync(sceneFile, JSON.stringify({ version: 1, robots: [{ id: "tiny", urdf: join(work, "tiny.urdf"), basePosition: [1, 0, 0] }], obstacles: [] }));
    const out = join(work, "placed");
    await generate(join(work, "tiny.urdf"), out, ["--scene", sceneFile, "--csv-joints"]);
    expect(json(join(out, "twin.json"))["robot"]["basePosition"]).toEqual([1, 0, 0]);
    expect(json(join(out, "scene.json"))["robots"]).toEqual([]);
    const csv = readCsv(join(out, "workspace.csv"));
    expect(csv.header).toEqual(["x", "y", "z", "collision_free", "yaw", "shoulder", "elbow"]);
    const summary = json(join(out, "workspace.json")) as Summary;
    // reach 0.5 m around the shoulder at (1, 0, 0.15)
    expect(summary.bounds.min[0]).toBeGreaterThan(0.45);
    expect(summary.bounds.max[0]).toBeLessThan(1.55);
  });

  it("a scene's other robot is reported, warned about within reach, and named when it stands where this robot stands", async () => {
    const near = join(work, "near.json");
    writeFileSync(near, JSON.stringify({ version: 1, robots: [{ id: "neighbour", urdf: "kuka_iiwa/model.urdf", basePosition: [0.3, 0.3, 0] }], obstacles: [] }));
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--samples", String(SAMPLES), "--out", join(work, "near"), "--scene", near]);
    expect(r.code, r.stderr).toBe(0);
    expect(r.stdout).toMatch(/scene {6}0 obstacle\(s\), 1 other robot\(s\): neighbour at \[0\.300, 0\.300, 0\.000\] m/);
    expect(r.stderr).toMatch(/robwot: warning: the scene's robot neighbour stands within this robot \(\w+\)'s reach \(0\.424 m apart\)/);
    const json = await generate(join(work, "tiny.urdf"), join(work, "near-json"), ["--scene", near]);
    expect(json["otherRobots"]).toEqual([{ id: "neighbour", basePosition: [0.3, 0.3, 0] }]);
    expect((json["warnings"] as string[])[0]).toMatch(/stands within this robot/);
    // at the same place nothing is collision-free: the refusal names the pairs and says why
    const same = join(work, "same.json");
    writeFileSync(same, JSON.stringify({ version: 1, robots: [{ id: "stowaway", urdf: "kuka_iiwa/model.urdf", basePosition: [0.01, 0, 0] }], obstacles: [] }));
    const bad = await runCli(["generate", join(work, "tiny.urdf"), "--samples", String(SAMPLES), "--out", join(work, "same"), "--scene", same]);
    expect(bad.code).toBe(1);
    expect(bad.stderr).toMatch(/no collision-free configuration .*stowaway\/lbr_iiwa_link_\d touches .*; this robot \(\w+\) and the scene's robot stowaway stand at the same place/);
  });

  it("--package-root resolves package:// meshes, which are copied into the folder", async () => {
    // outside the URDF's folder, so only --package-root can find it
    const pkg = join(mkdtempSync(join(tmpdir(), "robwot-pkg-")), "tinypkg");
    mkdirSync(join(pkg, "meshes"), { recursive: true });
    const stl = tetrahedronStl();
    writeFileSync(join(pkg, "meshes", "tip.stl"), stl);
    writeFileSync(join(work, "tiny-mesh.urdf"), withTipMesh("package://tinypkg/meshes/tip.stl"));
    const out = join(work, "with-mesh");
    const missing = await runCli(["generate", join(work, "tiny-mesh.urdf"), "--out", out, "--samples", "1000"]);
    expect(missing.code).not.toBe(0);
    expect(missing.stderr).toMatch(/robwot: error: .*tinypkg/);
    expect(existsSync(out)).toBe(false);
    await generate(join(work, "tiny-mesh.urdf"), out, ["--package-root", `tinypkg=${pkg}`]);
    const exported = readFileSync(join(out, "robot.urdf"), "utf8");
    const mesh = /<mesh\b[^>]*\bfilename="([^"]+)"/.exec(exported)?.[1];
    expect(mesh).toMatch(/^meshes\/.*tip\.stl$/);
    expect(readFileSync(join(out, mesh!)).equals(stl)).toBe(true);
    rmSync(join(pkg, ".."), { recursive: true, force: true });
  });

  it("a package without package.xml is the folder of its name holding the URDF, said in a warning", async () => {
    // as robots copied out of a ROS workspace come (the paper's dobot_description/{urdf,meshes}/)
    const pkg = join(work, "copied", "tinyarm_description");
    mkdirSync(join(pkg, "urdf"), { recursive: true });
    mkdirSync(join(pkg, "meshes"));
    const stl = tetrahedronStl();
    writeFileSync(join(pkg, "meshes", "tip.stl"), stl);
    writeFileSync(join(pkg, "urdf", "arm.urdf"), withTipMesh("package://tinyarm_description/meshes/tip.stl"));
    const out = join(work, "by-folder-name");
    const printed = await generate(join(pkg, "urdf", "arm.urdf"), out, ["--samples", "1000"]);
    const warnings = printed["warnings"] as string[];
    expect(warnings).toHaveLength(1);
    expect(warnings[0]).toContain(`${join(pkg, "urdf", "arm.urdf")}:`);
    expect(warnings[0]).toContain(`no package.xml names ROS package 'tinyarm_description'; taken as the folder ${pkg} by its name (give --package-root tinyarm_description=DIR to choose another)`);
    const mesh = /<mesh\b[^>]*\bfilename="([^"]+)"/.exec(readFileSync(join(out, "robot.urdf"), "utf8"))?.[1];
    expect(readFileSync(join(out, mesh!)).equals(stl)).toBe(true);
    // --package-root names the folder: nothing is guessed, nothing said
    const chosen = await runCli(["generate", join(pkg, "urdf", "arm.urdf"), "--samples", "1000", "--out", out, "--package-root", `tinyarm_description=${pkg}`]);
    expect(chosen.code, chosen.stderr).toBe(0);
    expect(chosen.stderr).not.toContain("no package.xml names");
  });
});

/** A binary STL tetrahedron (1 dm). */
function tetrahedronStl(): Buffer {
  const v = [[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]];
  const faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
  const stl = Buffer.alloc(84 + 50 * faces.length);
  stl.writeUInt32LE(faces.length, 80);
  faces.forEach((f, i) => f.forEach((vi, k) => v[vi]!.forEach((c, j) => stl.writeFloatLE(c, 84 + 50 * i + 12 + 12 * k + 4 * j))));
  return stl;
}

/** The tiny URDF with `filename` as the tip's collision mesh. */
function withTipMesh(filename: string): string {
  return TINY_URDF.replace('<link name="tip">', `<link name="tip"><collision><geometry><mesh filename="${filename}"/></geometry></collision>`);
}
