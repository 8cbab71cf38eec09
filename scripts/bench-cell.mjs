/**
 * `npm run bench:cell`: the remote-lab cell (README "A whole cell") generated as its two twins, served at
 * --realtime 0 with the lab devices' TDs (`--as`), and `consumer:lab-mashup` run --runs times against it
 * (the mashup returns the cube to its store: each run starts as the first); prints each run's cycle (wall
 * time of the mashup's steps, the TDs fetched before) and the median, then `python -m robwot_bench.cell`:
 * the cost of one simulated second of a cell with 10 objects moving. Quote the load average with it.
 *
 *   npm run bench:cell [-- --runs 5]
 */
import { spawnSync } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { loadavg, tmpdir } from "node:os";
import { join } from "node:path";
import { cli, repo, startCli } from "./bench-twin.mjs";

const runsAt = process.argv.indexOf("--runs");
const runs = runsAt >= 0 ? Number(process.argv[runsAt + 1]) : 5;
if (!Number.isInteger(runs) || runs < 1 || runs > 100) {
  console.error("usage: npm run bench:cell [-- --runs 1..100]");
  process.exit(2);
}
const cell = join(repo, "examples", "cells", "remote-lab");
const tmp = mkdtempSync(join(tmpdir(), "robwot-bench-cell-"));
const generate = (args, out) => {
  const r = spawnSync(process.execPath, [cli, "generate", ...args, "--scene", join(cell, "scene.json"), "--samples", "3000", "--out", join(tmp, out)], { encoding: "utf8" });
  if (r.status !== 0) {
    console.error(r.stderr);
    process.exit(r.status ?? 1);
  }
  return join(tmp, out);
};
const robots = join(repo, "examples", "robots");
const uarm = generate([join(robots, "uarm_like.urdf"), "--keep-level", "end", "--couple", "bar_joint=joint_2+joint_3", "--couple", "plate_joint=-joint_2", "--tcp", "0,0,-0.03", "--gripper", "suction"], "uarm");
const dobot = generate([join(robots, "dobot_like.urdf"), "--keep-level", "link_4", "--tcp", "0,0,-0.04", "--gripper", "suction"], "dobot");
const { child, info } = await startCli(["serve", uarm, dobot, "--port", "0", "--realtime", "0",
  "--as", `uarm=${join(repo, "examples", "as", "desk-arm.td.json")}`, "--as-map", `uarm=${join(cell, "uarm.map.json")}`,
  "--as", `warehouse=${join(cell, "warehouse.td.json")}`, "--as-map", `warehouse=${join(cell, "warehouse.map.json")}`]);
const cycles = [];
try {
  console.log("| run | mashup cycle (s) | infrared detections | colour |");
  console.log("|---|---|---|---|");
  for (let k = 1; k <= runs; k++) {
    const r = spawnSync(process.execPath, [join(repo, "packages", "consumers", "dist", "lab-mashup.js"), info.url, "--realtime", "0", "--json"], { encoding: "utf8" });
    const line = (r.stdout ?? "").split("\n").find((l) => l.startsWith("RESULT "));
    if (r.status !== 0 || !line) {
      console.error(r.stderr);
      process.exitCode = 1;
      break;
    }
    const result = JSON.parse(line.slice("RESULT ".length));
    cycles.push(result.cycle);
    console.log(`| ${k} | ${result.cycle.toFixed(2)} | ${JSON.stringify(result.detections)} | ${JSON.stringify(result.color)} |`);
  }
} finally {
  child.kill("SIGINT");
  await new Promise((r) => child.once("exit", r));
  rmSync(tmp, { recursive: true, force: true });
}
cycles.sort((a, b) => a - b);
if (cycles.length > 0) console.log(`\nmashup at --realtime 0: median ${cycles[Math.floor((cycles.length - 1) / 2)].toFixed(2)} s over ${cycles.length} runs; load average ${loadavg().map((v) => v.toFixed(2)).join(" ")}\n`);
const py = spawnSync(join(repo, "sim-backend", ".venv", "bin", "python"), ["-m", "robwot_bench.cell"], { stdio: "inherit" });
if (py.status !== 0) process.exitCode = py.status ?? 1;
