/**
 * A parallel-linkage arm end to end: `robwot generate --keep-level` (a Dobot-like fixture) derives the
 * coupling, records it, and the served twin takes only the joints a user drives; the passive joint is
 * set wherever the linkage puts it and the end stays level through a Cartesian move.
 */
import { mkdtempSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { http, invoke } from "./serve-helpers.js";

const ROBOTS = resolve(import.meta.dirname, "../examples/robots");
let work: string;
let folder: string;
let printed: { robot: { controllable: string[]; couplings: string[] } };
let s: RunningServient;
let base: string;

beforeAll(async () => {
  work = mkdtempSync(join(tmpdir(), "robwot-couple-"));
  folder = join(work, "dobot");
  const r = await runCli(["generate", join(ROBOTS, "dobot_like.urdf"), "--keep-level", "link_4", "--samples", "3000", "--out", folder, "--json"], { timeoutMs: 300_000 });
  expect(r.code, r.stderr).toBe(0);
  printed = JSON.parse(r.stdout) as typeof printed;
  s = await startServient({ twins: [folder], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => {
  await s?.stop();
  rmSync(work, { recursive: true, force: true });
});

describe("a coupled twin", () => {
  it("records the derived rule in twin.json and the TD, and serves only the leaders", async () => {
    expect(printed.robot.controllable).toEqual(["joint_1", "joint_2", "joint_3", "joint_5"]);
    expect(printed.robot.couplings).toEqual(["joint_4=-joint_2-joint_3"]);
    const manifest = JSON.parse(readFileSync(join(folder, "twin.json"), "utf8")) as { robot: { couplings: string[] } };
    expect(manifest.robot.couplings).toEqual(["joint_4=-joint_2-joint_3"]);
    const td = (await http(base)).body;
    expect(td["robwot:couplings"]).toEqual([{ follower: "joint_4", terms: [{ joint: "joint_2", factor: -1 }, { joint: "joint_3", factor: -1 }], offset: 0, expression: "joint_4=-joint_2-joint_3", source: "keep-level" }]);
    expect(Object.keys(td.actions.moveToJointPosition.input.properties.joints.properties)).toEqual(["joint_1", "joint_2", "joint_3", "joint_5"]);
    expect(Object.keys((await http(`${base}/properties/getJointPosition`)).body)).toEqual(["joint_1", "joint_2", "joint_3", "joint_5"]);
  });

  it("refuses the passive joint as an input", async () => {
    const r = await invoke(base, "moveToJointPosition", { joints: { joint_1: 0, joint_2: 0.5, joint_3: 0.2, joint_4: 0, joint_5: 0 } });
    expect(r.status).toBe(400);
  });

  it("reaches Cartesian targets with the end level: the orientation stays the start's turned by joint_1", async () => {
    const start = await invoke(base, "moveToJointPosition", { joints: { joint_1: 0, joint_2: 0.6, joint_3: 0.1, joint_5: 0 } });
    expect(start.status).toBe(200);
    const p = (await http(`${base}/properties/getCartesianPosition`)).body;
    const m = await invoke(base, "moveToCartesianPosition", { x: p.x - 0.03, y: p.y + 0.02, z: p.z + 0.04 });
    expect(m.status, JSON.stringify(m.body)).toBe(200);
    expect(m.body.status).toBe("reached");
    expect(m.body.positionError).toBeLessThan(1e-3);
    // link_5 hangs below the level bracket about a vertical axis: its z axis stays vertical
    const { x, y } = m.body.orientation as { x: number; y: number };
    expect(1 - 2 * (x * x + y * y)).toBeGreaterThan(Math.cos((0.1 * Math.PI) / 180));
  });
});
