/**
 * `robwot generate --srdf`: a robot as published for ROS/MoveIt (example-robot-data's Panda: mesh
 * collision geometry, package:// URIs, an SRDF) becomes a twin folder holding its SRDF (linked from the
 * TD, served) and its convex decompositions (collision/), and `serve` loads it with the SRDF's pairs
 * disabled. An SRDF of another robot's names is refused naming the file and line. `--clearance` reaches
 * twin.json, the TD and every validation report. Real CLI, backend and servient.
 */
import { execFileSync } from "node:child_process";
import { existsSync, mkdtempSync, readdirSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO, runCli } from "./cli-run.js";
import { http, invoke } from "./serve-helpers.js";

const PY = join(REPO, "sim-backend", ".venv", "bin", "python");
const ERD = execFileSync(PY, ["-c", "from robwot_bench.reference import example_robot_data; print(example_robot_data())"], { encoding: "utf8" }).trim();
const URDF = join(ERD, "robots", "panda_description", "urdf", "panda.urdf");
const SRDF = join(ERD, "robots", "panda_description", "srdf", "panda.srdf");
let out: string;
let s: RunningServient;

beforeAll(async () => {
  out = join(mkdtempSync(join(tmpdir(), "robwot-srdf-")), "panda");
  const r = await runCli(["generate", URDF, "--srdf", SRDF, "--package-root", `example-robot-data=${ERD}`, "--samples", "3000", "--clearance", "0.005", "--out", out], {
    timeoutMs: 300_000,
  });
  if (r.code !== 0) throw new Error(`generate failed: ${r.stderr}`);
  s = await startServient({ twins: [out], port: 0, realtime: 0 });
}, 300_000);
afterAll(async () => s?.stop());

describe("a MoveIt robot with its SRDF", () => {
  it("keeps the --clearance it was generated with: twin.json, the TD, every validation report; absurd values exit 2", async () => {
    expect(JSON.parse(readFileSync(join(out, "twin.json"), "utf8")).robot.clearance).toBe(0.005);
    const td = (await http(s.things[0]!.tdUrl)).body;
    expect(td["robwot:clearance"]).toBe(0.005);
    const ready = [0, -0.785, 0, -2.356, 0, 1.571, 0.785];
    const joints = Object.fromEntries(td["robwot:controllableJoints"].map((n: string, i: number) => [n, ready[i] ?? 0]));
    const v = await invoke(s.things[0]!.tdUrl, "validateJointPosition", { joints });
    expect(v.status).toBe(200);
    expect(v.body.checks.path.clearance).toBe(0.005);
    const bad = await runCli(["generate", "kuka_iiwa", "--clearance", "0.5", "--out", join(out, "..", "never")]);
    expect(bad.code).toBe(2);
    expect(bad.stderr).toContain("--clearance");
    expect(existsSync(join(out, "..", "never"))).toBe(false);
  });

  it("writes robot.srdf and the convex decompositions into the twin folder, and links the SRDF", async () => {
    expect(readFileSync(join(out, "robot.srdf"), "utf8")).toBe(readFileSync(SRDF, "utf8"));
    expect(JSON.parse(readFileSync(join(out, "twin.json"), "utf8")).robot.srdf).toBe("robot.srdf");
    expect(readdirSync(join(out, "collision")).length).toBeGreaterThan(0);
    const td = (await http(s.things[0]!.tdUrl)).body;
    expect(td.links).toContainEqual({ rel: "srdf", href: "robot.srdf", type: "application/xml" });
    const file = await http(`${s.things[0]!.tdUrl}/robot.srdf`);
    expect(file.status).toBe(200);
    expect(file.type).toContain("application/xml");
  });

  it("serve loads the robot with the SRDF's disabled pairs", () => {
    const twin = [...s.twins.values()][0]!;
    const pairs = new Set(((twin.model as unknown as { filteredPairs: [string, string][] }).filteredPairs ?? []).map((p) => [...p].sort().join("|")));
    expect(pairs.has(["panda_link6", "panda_link7"].sort().join("|")) || pairs.has(["panda_hand", "panda_link7"].sort().join("|"))).toBe(true);
    expect(pairs.size).toBeGreaterThan(10);
  });

  it("a bad SRDF (only unknown links: another robot's) is refused naming the file and line, nothing written", async () => {
    const dir = mkdtempSync(join(tmpdir(), "robwot-badsrdf-"));
    const bad = join(dir, "bad.srdf");
    writeFileSync(bad, '<robot name="panda">\n  <disable_collisions link1="no_such_link" link2="nor_this_one" reason="Never"/>\n</robot>\n');
    const r = await runCli(["generate", URDF, "--srdf", bad, "--package-root", `example-robot-data=${ERD}`, "--samples", "500", "--out", join(dir, "twin")], { timeoutMs: 120_000 });
    expect(r.code).toBe(1);
    expect(r.stderr).toContain(`${bad}:2`);
    expect(r.stderr).toContain("no_such_link");
    expect(existsSync(join(dir, "twin"))).toBe(false);
  });
});
