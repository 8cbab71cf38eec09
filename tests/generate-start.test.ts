/**
 * End to end: the twin's starting state. `generate` warns (before sampling) when the start pose collides
 * and when a scene's other robot stands where this one stands; `--home` sets the start pose (checked
 * against the joints and their limits); `serve` warns of a start pose in contact, and the twin may move
 * out of the contact but not deeper into it.
 */
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient } from "../packages/servient/src/index.js";
import { REPO, runCli } from "./cli-run.js";
import { generateTwin, invoke, kukaPose } from "./serve-helpers.js";

const SAMPLES = "2000";
/** a box through the KUKA's links 2 and 3 at all joints 0, on the +x side of the arm */
const BOX = { name: "box", shape: { type: "box", size: [0.1, 0.3, 0.1] }, position: [0.09, 0, 0.55] };
let work: string;
let scene: string;

beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-start-"));
  scene = join(work, "box-through.json");
  writeFileSync(scene, JSON.stringify({ version: 1, obstacles: [BOX] }));
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

/** The line index of the first workspace stage (sampling) in a plain progress log. */
const samplingLine = (lines: string[]): number => lines.findIndex((l) => /^robwot: (sample|collide|workspace)/.test(l));

describe("generate", () => {
  it("warns before sampling that the start pose collides, naming the bodies; --home moves it and is recorded", async () => {
    const r = await runCli(["generate", "kuka_iiwa", "--samples", SAMPLES, "--out", join(work, "in-box"), "--scene", scene]);
    expect(r.code, r.stderr).toBe(0);
    const lines = r.stderr.split("\n");
    const at = lines.findIndex((l) => l.startsWith("robwot: warning: the start pose (the robot as loaded) collides (lbr_iiwa/lbr_iiwa_link_"));
    expect(at, r.stderr).toBeGreaterThanOrEqual(0);
    expect(lines[at]).toMatch(/ with box \(\d+\.\d mm deep\)/);
    expect(at).toBeLessThan(samplingLine(lines));
    expect(lines.filter((l) => l.includes("start pose"))).toHaveLength(1); // said once, not again at the end

    const home = await runCli(["generate", "kuka_iiwa", "--samples", SAMPLES, "--out", join(work, "home"), "--scene", scene, "--home", "lbr_iiwa_joint_2=-1.0, lbr_iiwa_joint_4=0.5", "--json"]);
    expect(home.code, home.stderr).toBe(0);
    expect((JSON.parse(home.stdout) as { warnings: string[] }).warnings).toEqual([]);
    const manifest = JSON.parse(readFileSync(join(work, "home", "twin.json"), "utf8")) as { robot: { home: unknown } };
    expect(manifest.robot.home).toEqual({ joints: kukaPose([0, -1.0, 0, 0.5, 0, 0, 0]), from: "--home" });
  });

  it.each([
    ["an unknown joint", "elbow=0.1", /--home elbow=0\.1: elbow is not a joint of the robot; the robot's controllable joints: lbr_iiwa_joint_1, /],
    ["a value outside the limits", "lbr_iiwa_joint_2=3", /--home lbr_iiwa_joint_2=3 is outside the joint's limits \[-2\.09\d*, 2\.09\d*\]/],
    ["a malformed list", "lbr_iiwa_joint_2", /--home must be JOINT=VALUE,\.\.\./],
  ])("refuses %s before sampling and writes nothing", async (_what, value, message) => {
    const out = join(work, `bad-${value.length}`);
    const r = await runCli(["generate", "kuka_iiwa", "--samples", SAMPLES, "--out", out, "--home", value]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(message);
    expect(samplingLine(r.stderr.split("\n"))).toBe(-1);
    expect(() => readFileSync(join(out, "twin.json"))).toThrow();
  });

  it("says before sampling that a scene copied from table.json brings a robot standing where this one stands", async () => {
    const copy = join(work, "my-table.json");
    writeFileSync(copy, readFileSync(join(REPO, "examples", "scenes", "table.json")));
    const r = await runCli(["generate", "xarm6", "--samples", SAMPLES, "--out", join(work, "xarm"), "--scene", copy]);
    const lines = r.stderr.split("\n");
    const at = lines.findIndex((l) => /^robwot: warning: this robot \(\w+\) and the scene's robot kuka stand at the same place/.test(l));
    expect(at, r.stderr).toBeGreaterThanOrEqual(0);
    const sampling = samplingLine(lines);
    expect(sampling === -1 || at < sampling, r.stderr).toBe(true);
  });
});

describe("serve", () => {
  it("warns of a twin whose start pose collides; moves out of the contact run, moves deeper are refused saying why", async () => {
    const dir = await generateTwin("kuka_iiwa", 2000, ["--scene", scene]);
    const warned: string[] = [];
    const onWarning = (w: Error & { code?: string }): void => void (w.code === "ROBWOT_START_COLLIDES" && warned.push(w.message));
    process.on("warning", onWarning);
    const s = await startServient({ twins: [dir], port: 0, realtime: 0 });
    try {
      await new Promise((r) => setImmediate(r)); // process warnings are emitted on the next tick
      expect(warned).toHaveLength(1);
      expect(warned[0]).toMatch(/^robwot serve: twin lbr_iiwa: its start pose collides \(lbr_iiwa\/lbr_iiwa_link_\d with box/);
      const base = s.things[0]!.tdUrl;
      const deeper = await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 1.2, 0, 0, 0, 0, 0]) });
      expect(deeper.status).toBe(422);
      expect(JSON.stringify(deeper.body)).toContain("the current state already collides (lbr_iiwa/lbr_iiwa_link_");
      const out = await invoke(base, "moveToJointPosition", { joints: kukaPose([0, -1.0, 0, 0, 0, 0, 0]) });
      expect(out.status, JSON.stringify(out.body)).toBe(200);
    } finally {
      process.off("warning", onWarning);
      await s.stop();
    }
  });
});
