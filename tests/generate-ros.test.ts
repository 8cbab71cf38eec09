/**
 * `robwot generate` with robots as ROS users have them, placed where they stand: `--base` (twin.json,
 * the served pose), xacro files with `--xacro-arg`, unexpanded xacro refused with file:line, and
 * `package://` resolved from ROS_PACKAGE_PATH or refused with the option that fixes it. Real CLI, backend
 * and servient.
 */
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient } from "../packages/servient/src/index.js";
import { runCli, TINY_URDF } from "./cli-run.js";
import { http } from "./serve-helpers.js";

const SAMPLES = "2000";
let work: string;

beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-ros-"));
  writeFileSync(join(work, "tiny.urdf"), TINY_URDF);
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

const json = (file: string): Record<string, any> => JSON.parse(readFileSync(file, "utf8")) as Record<string, any>;

describe("--base X,Y,Z[,ROLL,PITCH,YAW]", () => {
  it("places the robot: twin.json holds the pose, serve reports the end effector shifted and turned by it", async () => {
    const out = join(work, "based");
    // roll = pi/2 turns the arm's +Z (tip 0.65 m above the base at zero joints) into -Y
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--base", `1, 2,0.5,${Math.PI / 2},0,0`, "--samples", SAMPLES, "--out", out]);
    expect(r.code, r.stderr).toBe(0);
    const robot = json(join(out, "twin.json")).robot;
    expect(robot.basePosition).toEqual([1, 2, 0.5]);
    const s = Math.SQRT1_2;
    robot.baseOrientation.forEach((v: number, i: number) => expect(v).toBeCloseTo([s, 0, 0, s][i]!, 9));
    // the workspace is sampled in the world frame: every point lies on the base's side
    const bounds = json(join(out, "workspace.json")).bounds;
    expect(bounds.max[1]).toBeLessThan(2 + 0.2);
    expect(bounds.min[1]).toBeLessThan(2 - 0.5);
    const served = await startServient({ twins: [out], port: 0, realtime: 0 });
    try {
      const pose = (await http(`${served.things[0]!.tdUrl}/properties/getCartesianPosition`)).body;
      expect(pose.x).toBeCloseTo(1, 6);
      expect(pose.y).toBeCloseTo(2 - 0.65, 6);
      expect(pose.z).toBeCloseTo(0.5, 6);
    } finally {
      await served.stop();
    }
  }, 180_000);

  it.each([
    ["1,2", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["1,2,3,4", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["1,,3", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["a,b,c", "X,Y,Z or X,Y,Z,ROLL,PITCH,YAW"],
    ["0,0,1e9", "within ±10000 m"],
    ["0,0,0,0,0,1e5", "within ±10000 rad"],
  ])("refuses --base %s with a usage error naming the option", async (value, says) => {
    const out = join(work, "never-base");
    const r = await runCli(["generate", join(work, "tiny.urdf"), `--base=${value}`, "--out", out]);
    expect(r.code).toBe(2);
    expect(r.stderr).toContain("--base");
    expect(r.stderr).toContain(says);
    expect(existsSync(out)).toBe(false);
  });

  it("refuses --base when the scene places the same robot too", async () => {
    const scene = join(work, "placing.scene.json");
    writeFileSync(scene, JSON.stringify({ version: 1, obstacles: [], robots: [{ urdf: join(work, "tiny.urdf"), basePosition: [0.3, 0, 0] }] }));
    const out = join(work, "never-both");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--scene", scene, "--base", "1,0,0", "--samples", SAMPLES, "--out", out]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/--base places the robot, but the scene .*placing\.scene\.json places it too/);
    expect(existsSync(out)).toBe(false);
  }, 60_000);
});
