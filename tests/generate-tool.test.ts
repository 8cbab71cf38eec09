/**
 * `robwot generate --tcp ... --tool-mesh ...`: the tool is in robot.urdf (links robwot_tool, robwot_tcp),
 * its mesh copied, twin.json and the TD describe it, and the served Cartesian pose is the TCP's.
 */
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, expect, it } from "vitest";
import { writeStl } from "../packages/core/src/index.js";
import { startServient } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { http } from "./serve-helpers.js";

const work = mkdtempSync(join(tmpdir(), "robwot-tool-"));
afterAll(() => rmSync(work, { recursive: true, force: true }));
const json = (file: string): Record<string, any> => JSON.parse(readFileSync(file, "utf8")) as Record<string, any>;

/** A 4 x 4 x 12 cm block along the flange's z axis (its frame), as 12 triangles. */
function gripperStl(): Uint8Array {
  const [x0, x1, y0, y1, z0, z1] = [-0.02, 0.02, -0.02, 0.02, 0, 0.12];
  const c = (i: number) => [i & 1 ? x1 : x0, i & 2 ? y1 : y0, i & 4 ? z1 : z0];
  const quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
  return writeStl(quads.flatMap(([a, b, cc, d]) => [...c(a!), ...c(b!), ...c(cc!), ...c(a!), ...c(cc!), ...c(d!)]));
}

async function servedPose(dir: string): Promise<{ x: number; y: number; z: number }> {
  const s = await startServient({ twins: [dir], port: 0, realtime: 0 });
  try {
    return (await http(`${s.things[0]!.tdUrl}/properties/getCartesianPosition`)).body;
  } finally {
    await s.stop();
  }
}

it("a tool on the KUKA's flange: the TCP is the end effector, described in twin.json and the TD", async () => {
  const mesh = join(work, "gripper.stl");
  writeFileSync(mesh, gripperStl());
  const tooled = join(work, "tooled");
  const plain = join(work, "plain");
  const r = await runCli(["generate", "kuka_iiwa", "--tcp", "0,0,0.15", "--tool-mesh", mesh, "--samples", "2000", "--out", tooled]);
  expect(r.code, r.stderr).toBe(0);
  expect((await runCli(["generate", "kuka_iiwa", "--samples", "2000", "--out", plain])).code).toBe(0);

  const robot = json(join(tooled, "twin.json"))["robot"];
  expect(robot.eeLink).toBe("robwot_tcp");
  expect(robot.tool).toEqual({ flange: "lbr_iiwa_link_7", tcp: [0, 0, 0.15, 0, 0, 0], mesh: "gripper.stl" });
  const urdf = readFileSync(join(tooled, "robot.urdf"), "utf8");
  // the tool's mesh beside the KUKA's, never under a copy of the machine's absolute paths
  expect(urdf).toMatch(/<link name="robwot_tool">[\s\S]*<mesh filename="meshes\/robwot_tool\.stl"/);
  expect(urdf).toMatch(/<mesh filename="meshes\/link_0\.stl"/);
  expect(urdf).toMatch(/<joint name="robwot_tcp_joint" type="fixed">[\s\S]*<origin xyz="0 0 0.15" rpy="0 0 0"/);
  const td = json(join(tooled, "td.json"));
  expect(td["robwot:eeLink"]).toBe("robwot_tcp");
  expect(td["robwot:tool"]).toEqual({ flange: "lbr_iiwa_link_7", tcp: { xyz: [0, 0, 0.15], rpy: [0, 0, 0], unit: ["m", "rad"] }, mesh: "gripper.stl" });
  expect(td.description).toContain("the TCP of a tool on 'lbr_iiwa_link_7'");

  // at the zero pose the KUKA's flange points up: the TCP is 15 cm above it
  const [a, b] = [await servedPose(tooled), await servedPose(plain)];
  expect(a.x).toBeCloseTo(b.x, 6);
  expect(a.y).toBeCloseTo(b.y, 6);
  expect(a.z - b.z).toBeCloseTo(0.15, 6);
  // the workspace refers to the TCP: its reach box reaches 15 cm further up
  expect(json(join(tooled, "workspace.json"))["reachBounds"].max[2] - json(join(plain, "workspace.json"))["reachBounds"].max[2]).toBeCloseTo(0.15, 2);
}, 300_000);

it("a scene that places the robot places it with its tool too (the scene names the file, the twin loads its copy)", async () => {
  const scene = join(work, "placed.json");
  writeFileSync(scene, JSON.stringify({ version: 1, robots: [{ id: "kuka", urdf: "kuka_iiwa/model.urdf", basePosition: [1, 0, 0] }], obstacles: [] }));
  const out = join(work, "placed");
  const r = await runCli(["generate", "kuka_iiwa", "--tcp", "0,0,0.1", "--scene", scene, "--samples", "1000", "--out", out]);
  expect(r.code, r.stderr).toBe(0);
  expect(json(join(out, "twin.json"))["robot"]["basePosition"]).toEqual([1, 0, 0]);
  expect(json(join(out, "scene.json"))["robots"]).toEqual([]); // not a second KUKA standing in it
  expect(r.stderr).not.toMatch(/warning/);
}, 120_000);

it("--tool-box: the tool as a box from the flange along its z axis, recorded in twin.json and the TD", async () => {
  const out = join(work, "boxed");
  const r = await runCli(["generate", "kuka_iiwa", "--tcp", "0,0,0.12", "--tool-box", "0.04,0.04,0.12", "--samples", "1000", "--out", out]);
  expect(r.code, r.stderr).toBe(0);
  const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
  expect(urdf).toMatch(/<link name="robwot_tool">[\s\S]*<collision>\s*<origin xyz="0 0 0.06" rpy="0 0 0" \/>\s*<geometry>\s*<box size="0.04 0.04 0.12" \/>/);
  expect(json(join(out, "twin.json"))["robot"]["tool"]).toEqual({ flange: "lbr_iiwa_link_7", tcp: [0, 0, 0.12, 0, 0, 0], shape: { type: "box", size: [0.04, 0.04, 0.12] } });
  expect(json(join(out, "td.json"))["robwot:tool"].shape).toEqual({ type: "box", size: [0.04, 0.04, 0.12] });
}, 120_000);

it("refuses a bad --tcp and a missing --tool-mesh before any work", async () => {
  const bad = await runCli(["generate", "kuka_iiwa", "--tcp", "0,0", "--out", join(work, "never")]);
  expect(bad.code).toBe(2);
  expect(bad.stderr).toContain('--tcp must be X,Y,Z or X,Y,Z,ROLL,PITCH,YAW (metres, radians), got "0,0"');
  const missing = await runCli(["generate", "kuka_iiwa", "--tool-mesh", join(work, "nope.stl"), "--out", join(work, "never")]);
  expect(missing.code).toBe(1); // as every missing input file
  expect(missing.stderr).toMatch(/robwot: error: tool mesh not found: .*nope\.stl/);
  const both = await runCli(["generate", "kuka_iiwa", "--tool-box", "0.1,0.1,0.1", "--tool-cylinder", "0.1,0.2", "--out", join(work, "never")]);
  expect(both.code).toBe(2);
  expect(both.stderr).toContain("give --tool-box or --tool-cylinder, not both");
  const flat = await runCli(["generate", "kuka_iiwa", "--tool-cylinder", "0.1,0", "--out", join(work, "never")]);
  expect(flat.code).toBe(2);
  expect(flat.stderr).toContain('--tool-cylinder must be RADIUS,LENGTH (metres, each in (0, 10]), got "0.1,0"');
});
