/**
 * A twin folder is a jail: hostile folders, made by copying a generated KUKA twin and planting paths
 * out of it, symlinks to other files and broken convex parts, are refused by the real `serve` naming
 * the file and the entry; errors never quote another file's bytes; a part PyBullet would crash on is
 * refused by our parser (the backend lives to say so); a missing part is refused at once, never
 * decomposed again. Real servient, real backend, real CLI.
 */
import { copyFileSync, mkdtempSync, readdirSync, readFileSync, renameSync, statSync, symlinkSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO, runCli } from "./cli-run.js";
import { generateTwin, live } from "./serve-helpers.js";

const CUBE = join(REPO, "sim-backend", "tests", "models", "meshes", "cube.stl");
let outside: string;
let pristine: string;

beforeAll(async () => {
  pristine = await generateTwin("kuka_iiwa", 3000);
  outside = mkdtempSync(join(tmpdir(), "robwot-jail-outside-"));
  copyFileSync(CUBE, join(outside, "secret.stl"));
}, 600_000);

/** A private copy of the generated twin to plant hostile files in. */
async function twin(): Promise<string> {
  return generateTwin("kuka_iiwa", 3000);
}

const json = (file: string): any => JSON.parse(readFileSync(file, "utf8"));
const edit = (file: string, change: (doc: any) => void): void => {
  const doc = json(file);
  change(doc);
  writeFileSync(file, JSON.stringify(doc));
};

/** The first cached decomposition of the twin that has convex parts: its folder and manifest. */
function partsFolder(dir: string): { folder: string; parts: string[] } {
  for (const key of readdirSync(join(dir, "collision"))) {
    const folder = join(dir, "collision", key);
    const parts = json(join(folder, "parts.json")).parts as string[];
    if (parts.length > 0) return { folder, parts };
  }
  throw new Error(`no decomposed mesh in ${dir}/collision`);
}

/** startServient's refusal (it must refuse, not serve). */
async function refusal(dir: string, meshRoots: string[] = []): Promise<{ code: string; message: string; details: any }> {
  let s: RunningServient | undefined;
  try {
    s = await startServient({ twins: [dir], port: 0, realtime: 0, meshRoots });
  } catch (err) {
    const e = err as { code?: string; message: string; details?: unknown; data?: unknown };
    return { code: e.code ?? "", message: e.message, details: e.details ?? e.data ?? {} };
  }
  await s.stop();
  throw new Error(`serve accepted the hostile folder ${dir}`);
}

describe("twin.json and scene.json paths stay in the folder", () => {
  it.each([
    ["robot.urdf", (d: any) => (d.robot.urdf = "../../../etc/passwd")],
    ["robot.srdf", (d: any) => (d.robot.srdf = "../../../etc/passwd")],
    ["scene", (d: any) => (d.scene = "../../../etc/passwd")],
    ["robot.urdf", (d: any) => (d.robot.urdf = "/etc/passwd")],
  ])("twin.json %s out of the folder is refused naming the file and the entry", async (entry, plant) => {
    const dir = await twin();
    edit(join(dir, "twin.json"), plant);
    const r = await refusal(dir);
    expect(r.code).toBe("E_TWIN_FOLDER");
    expect(r.message).toContain(`${join(dir, "twin.json")}: ${entry} "`);
    expect(r.message).toMatch(/resolves outside the twin folder/);
    expect(r.message).not.toContain("root:");
  });

  it("twin.json's robot.urdf as a symlink out of the folder is refused", async () => {
    const dir = await twin();
    symlinkSync(join(pristine, "robot.urdf"), join(dir, "elsewhere.urdf"));
    edit(join(dir, "twin.json"), (d) => (d.robot.urdf = "elsewhere.urdf"));
    const r = await refusal(dir);
    expect(r.message).toMatch(/robot\.urdf "elsewhere\.urdf" resolves outside the twin folder/);
  });

  it("a scene mesh obstacle with an absolute path outside is refused, and served from a --mesh-root", async () => {
    const dir = await twin();
    const rock = { name: "rock", shape: { type: "mesh", file: join(outside, "secret.stl") }, position: [2, 2, 0] };
    edit(join(dir, "scene.json"), (d) => (d.obstacles = [rock]));
    const r = await refusal(dir);
    expect(r.code).toBe("E_TWIN_FOLDER");
    expect(r.message).toContain(`scene.json: obstacle "rock" mesh "${join(outside, "secret.stl")}" resolves outside the twin folder and the --mesh-root folders`);

    const s = await startServient({ twins: [dir], port: 0, realtime: 0, meshRoots: [outside] });
    try {
      const ws = await live(s.liveUrl);
      ws.ws.send(JSON.stringify({ subscribe: s.things[0]!.slug }));
      const scene = await ws.waitFor((m) => m.type === "scene");
      expect(scene.obstacles.map((o: any) => o.name)).toEqual(["rock"]);
      ws.close();
    } finally {
      await s.stop();
    }
  }, 120_000);

  it("a scene mesh obstacle climbing out with ../ is refused", async () => {
    const dir = await twin();
    const rock = { name: "rock", shape: { type: "mesh", file: `../../${outside.split("/").pop()}/secret.stl` }, position: [2, 2, 0] };
    edit(join(dir, "scene.json"), (d) => (d.obstacles = [rock]));
    const r = await refusal(dir, [outside]);
    expect(r.message).toMatch(/obstacle "rock" mesh ".*secret\.stl" resolves outside/);
  });
});

describe("a folder's files symlinked elsewhere are refused unread", () => {
  it.each(["workspace.csv", "reachability.csv", "td.json", "workspace.json", "scene.json"])("%s -> /etc/passwd: refused naming it, no byte of /etc/passwd in the error", async (name) => {
    const dir = await twin();
    renameSync(join(dir, name), join(dir, `${name}.orig`));
    symlinkSync("/etc/passwd", join(dir, name));
    const r = await refusal(dir);
    expect(r.code).toBe("E_TWIN_FOLDER");
    expect(r.message).toContain(name);
    expect(r.message).toMatch(/outside the twin folder/);
    expect(r.message).not.toContain("root:");
    expect(JSON.stringify(r.details)).not.toContain("root:");
  });

  it("robwot serve with workspace.csv -> /etc/passwd exits 1 without quoting it", async () => {
    const dir = await twin();
    renameSync(join(dir, "workspace.csv"), join(dir, "workspace.csv.orig"));
    symlinkSync("/etc/passwd", join(dir, "workspace.csv"));
    const r = await runCli(["serve", dir, "--port", "0"], { timeoutMs: 60_000 });
    expect(r.code).not.toBe(0);
    expect(r.stderr).toMatch(/workspace\.csv/);
    expect(r.stdout + r.stderr).not.toContain("root:");
  });
});

describe("collision/<key>/parts.json stays in its folder (the backend checks it)", () => {
  it.each([
    ["an absolute entry", (folder: string, part: string) => {
      copyFileSync(join(folder, part), join(outside, part));
      return join(outside, part);
    }],
    ["a ../ entry", (folder: string, part: string) => {
      // folder = <tmp>/<copy>/kuka_iiwa/collision/<key>: four levels up is <tmp>, where `outside` lives
      copyFileSync(join(folder, part), join(outside, `up-${part}`));
      return `../../../../${outside.split("/").pop()}/up-${part}`;
    }],
    ["a symlink out", (folder: string, part: string) => {
      copyFileSync(join(folder, part), join(outside, `link-${part}`));
      symlinkSync(join(outside, `link-${part}`), join(folder, "link.obj"));
      return "link.obj";
    }],
  ])("%s is refused (E_PATH_ESCAPE naming parts.json)", async (_what, plant) => {
    const dir = await twin();
    const { folder, parts } = partsFolder(dir);
    const entry = plant(folder, parts[0]!);
    edit(join(folder, "parts.json"), (d) => (d.parts = [entry, ...parts.slice(1)]));
    const r = await refusal(dir);
    expect(r.code).toBe("E_PATH_ESCAPE");
    expect(r.message).toContain(join(folder, "parts.json"));
  }, 120_000);
});

describe("convex parts pass our mesh parser before PyBullet", () => {
  it.each([
    ["a face index of 1,000,000", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 1000000\n", /line 4: face index 1000000 outside the 3 vertices/],
    ["a face without vertices", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\nf\n", /line 5: a face needs at least 3 vertices/],
  ])("a part with %s is refused naming the file (E_MESH), the backend does not crash", async (_what, text, reason) => {
    const dir = await twin();
    const { folder, parts } = partsFolder(dir);
    writeFileSync(join(folder, parts[0]!), text);
    const r = await refusal(dir);
    expect(r.code).toBe("E_MESH");
    expect(r.message).toContain(join(folder, parts[0]!));
    expect(r.message).toMatch(reason);
    expect(r.message).not.toMatch(/1006|connection closed/);
  }, 120_000);

  it("robwot serve with a part of face index 1,000,000 exits naming the part, not 'connection closed'", async () => {
    const dir = await twin();
    const { folder, parts } = partsFolder(dir);
    writeFileSync(join(folder, parts[0]!), "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 1000000\n");
    const r = await runCli(["serve", dir, "--port", "0"], { timeoutMs: 120_000 });
    expect(r.code).not.toBe(0);
    expect(r.stderr).toContain(parts[0]!);
    expect(r.stderr).toMatch(/face index 1000000/);
    expect(r.stderr).not.toMatch(/1006|connection closed/);
  }, 150_000);

  it("a parts.json naming a missing part is refused at once: nothing is decomposed", async () => {
    const dir = await twin();
    const { folder, parts } = partsFolder(dir);
    edit(join(folder, "parts.json"), (d) => (d.parts = [...parts, "part999.obj"]));
    const cache = join(dir, "collision");
    const before = readdirSync(cache).sort();
    const mtime = statSync(cache).mtimeMs;
    const r = await refusal(dir);
    expect(r.code).toBe("E_MESH");
    expect(r.message).toContain(join(folder, "part999.obj"));
    expect(r.message).toMatch(/missing.*robwot generate/);
    // a decomposition writes a new folder into the cache: none was written
    expect(readdirSync(cache).sort()).toEqual(before);
    expect(statSync(cache).mtimeMs).toBe(mtime);
  }, 120_000);

  it("a folder without its convex parts is refused (re-run generate), never decomposed at serve time", async () => {
    const dir = await twin();
    // parts are found by the mesh's content (the twin's collision/, else the parts shipped for the bundled
    // robots): a mesh edited after generate has none anywhere
    const before = readdirSync(join(dir, "collision")).sort();
    // the collision meshes are binary STL: a new 80-byte header changes their content, not their shape
    const meshes = readdirSync(join(dir, "meshes"), { recursive: true }).map(String).filter((f) => f.endsWith(".stl"));
    expect(meshes.length).toBeGreaterThan(0);
    for (const f of meshes) {
      const data = readFileSync(join(dir, "meshes", f));
      Buffer.from("edited after robwot generate".padEnd(80, " ")).copy(data, 0);
      writeFileSync(join(dir, "meshes", f), data);
    }
    const r = await refusal(dir);
    expect(r.code).toBe("E_MESH");
    expect(r.message).toMatch(/is concave and has no convex parts.*re-run robwot generate/);
    expect(readdirSync(join(dir, "collision")).sort()).toEqual(before);
  }, 120_000);
});

describe("a scene's other robots load from inside the folder", () => {
  const UR3 = join(REPO, "packages", "cli", "robots", "ur3.urdf");
  let withNeighbour: string;
  let scene: string;

  beforeAll(async () => {
    scene = join(mkdtempSync(join(tmpdir(), "robwot-jail-scene-")), "neighbour.json");
    writeFileSync(scene, JSON.stringify({ version: 1, robots: [{ id: "neighbour", urdf: UR3, basePosition: [1.5, 0, 0] }] }));
    withNeighbour = await generateTwin("kuka_iiwa", 3000, ["--scene", scene]);
  }, 600_000);

  it("generate exports the other robot into robots/<id>/ and serve loads it from there", async () => {
    const doc = json(join(withNeighbour, "scene.json"));
    expect(doc.robots[0].urdf).toBe("robots/neighbour/robot.urdf");
    expect(statSync(join(withNeighbour, "robots", "neighbour", "robot.urdf")).isFile()).toBe(true);
    const s = await startServient({ twins: [withNeighbour], port: 0, realtime: 0 });
    try {
      const world = await s.backend.sim.listWorld();
      expect(world.robots.map((r) => r.id).sort()).toEqual(["lbr_iiwa", "neighbour"]);
      const neighbour = world.robots.find((r) => r.id === "neighbour")!;
      expect(neighbour.urdf).toMatch(/robots\/neighbour\/robot\.urdf$/);
    } finally {
      await s.stop();
    }
  }, 300_000);

  it.each([
    ["an absolute URDF outside the folder", (r: any) => (r.urdf = UR3), /robot "neighbour" urdf .*outside the twin folder/],
    ["a relative URDF out of the folder", (r: any) => (r.urdf = "../../../../etc/passwd"), /robot "neighbour" urdf/],
    ["package roots", (r: any) => (r.packageRoots = { evil: "/" }), /robot "neighbour" names packageRoots/],
  ])("a scene robot with %s refuses the folder, naming the robot", async (_what, change, message) => {
    const copy = await generateTwin("kuka_iiwa", 3000, ["--scene", scene]); // a fresh copy of the same twin
    edit(join(copy, "scene.json"), (doc) => change(doc.robots[0]));
    await expect(startServient({ twins: [copy], port: 0, realtime: 0 })).rejects.toMatchObject({ code: "E_TWIN_FOLDER", message: expect.stringMatching(message) });
  }, 300_000);
});
