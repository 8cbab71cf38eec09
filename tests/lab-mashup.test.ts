/**
 * End to end, the paper's mashup: the remote-lab cell (examples/cells/remote-lab) generated as two twins
 * by the real CLI (the uArm-like and Dobot-like arms with suction grippers, both in the cell's scene),
 * served by the real servient with the lab devices' own TDs (`--as`: the uArm's, the warehouse's with its
 * getCube / returnCube sequences), the conveyors and sensors as Things; `consumer:lab-mashup` (node-wot,
 * against those TDs only) runs the paper's sequence at the fastest rate (three times in a row on one cell) and at real time. Checked from
 * outside: the cube ends back in its store, each infrared sensor fired once, the colour read is the cube's.
 */
import { join } from "node:path";
import { mkdtempSync } from "node:fs";
import { tmpdir } from "node:os";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO, runCli, runNode } from "./cli-run.js";
import { http } from "./serve-helpers.js";

const CELL = join(REPO, "examples", "cells", "remote-lab");
const MASHUP = join(REPO, "packages", "consumers", "dist", "lab-mashup.js");
const STORE = [0.4, 0.0, 0.0325]; // the cube resting on its store (scene.json)

const dir = mkdtempSync(join(tmpdir(), "robwot-lab-"));
const generate = async (args: string[], out: string): Promise<string> => {
  const r = await runCli(["generate", ...args, "--scene", join(CELL, "scene.json"), "--samples", "3000", "--out", join(dir, out)], { timeoutMs: 300_000 });
  if (r.code !== 0) throw new Error(`robwot generate failed (${r.code}): ${r.stderr}`);
  return join(dir, out);
};
let twins: string[];
beforeAll(async () => {
  twins = [
    await generate([join(REPO, "examples", "robots", "uarm_like.urdf"), "--keep-level", "end", "--couple", "bar_joint=joint_2+joint_3", "--couple", "plate_joint=-joint_2", "--tcp", "0,0,-0.03", "--gripper", "suction"], "uarm"),
    await generate([join(REPO, "examples", "robots", "dobot_like.urdf"), "--keep-level", "link_4", "--tcp", "0,0,-0.04", "--gripper", "suction"], "dobot"),
  ];
}, 600_000);

const serve = (realtime: number): Promise<RunningServient> =>
  startServient({
    twins,
    port: 0,
    realtime,
    as: [
      { name: "uarm", td: join(REPO, "examples", "as", "desk-arm.td.json"), map: join(CELL, "uarm.map.json") },
      { name: "warehouse", td: join(CELL, "warehouse.td.json"), map: join(CELL, "warehouse.map.json") },
    ],
  });

let s: RunningServient | undefined;
afterAll(async () => s?.stop());

it.each([0, 1])("runs the paper's mashup end to end at --realtime %s", async (realtime) => {
  s = await serve(realtime);
  try {
    const listed = ((await http(`${s.url}/things`)).body as { title: string }[]).map((t) => t.title).sort();
    expect(listed).toEqual(["DeskArm", "Warehouse", "colorSensor", "conveyor1", "conveyor2", "dobot_like", "infraredSensor1", "infraredSensor2", "uarm_like"].sort());
    // at the fastest rate, run after run on one cell (each starts where the last left the cube)
    for (let k = 0; k < (realtime === 0 ? 3 : 1); k++) {
      const run = await runNode(MASHUP, [s.url, "--realtime", String(realtime), "--json"], { timeoutMs: 240_000 });
      expect(run.code, `run ${k + 1}: ${run.stderr}`).toBe(0);
      const line = run.stdout.split("\n").find((l) => l.startsWith("RESULT "));
      const result = JSON.parse(line!.slice("RESULT ".length));
      expect(result.detections).toEqual({ infraredsensor1: 1, infraredsensor2: 1 });
      expect(result.color).toEqual({ r: 26, g: 76, b: 230 }); // the cube's colour [0.1, 0.3, 0.9] as 0-255
      const cube = ((await http(`${s.url}/uarm_like/properties/objects`)).body as { name: string; position: number[] }[]).find((o) => o.name === "cube")!;
      for (let j = 0; j < 3; j++) expect(Math.abs(cube.position[j]! - STORE[j]!)).toBeLessThan(0.01);
    }
  } finally {
    await s.stop();
    s = undefined;
  }
}, 300_000);
