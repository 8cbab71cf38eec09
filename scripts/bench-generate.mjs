#!/usr/bin/env node
// Scene-complexity benchmark of `robwot generate` (the original's experiment: UR3, 80,000 samples,
// 13.9 s with 4 obstacles -> 281.9 s with 239). Every run is a full CLI process, backend start included.
//
//   npm run bench:generate                       # 4 robots x 4 scenes x 3 runs = 48 generate processes
//   npm run bench:generate -- --runs 1 --samples 20000 --robots kuka_iiwa,ur3
//   options: --runs N, --samples N, --robots a,b, --scenes 4,66,135,239, --workers N, --json FILE
import { spawnSync } from "node:child_process";
import { existsSync, mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { parseArgs } from "node:util";

const root = join(dirname(fileURLToPath(import.meta.url)), "..");
const cli = join(root, "packages", "cli", "dist", "main.js");
const ORIGINAL = { robot: "UR3 (original)", seconds: { 4: 13.9, 239: 281.9 } };

const { values } = parseArgs({
  options: {
    runs: { type: "string", default: "3" },
    samples: { type: "string", default: "80000" },
    robots: { type: "string", default: "kuka_iiwa,franka_panda,xarm6,ur3" },
    scenes: { type: "string", default: "4,66,135,239" },
    workers: { type: "string" },
    json: { type: "string" },
  },
});
const runs = Number(values.runs);
const samples = Number(values.samples);
const robots = values.robots.split(",").filter(Boolean);
const scenes = values.scenes.split(",").filter(Boolean).map(Number);
if (!existsSync(cli)) {
  console.error(`bench-generate: ${cli} not found: run npm run build first`);
  process.exit(1);
}
for (const n of scenes) {
  const f = join(root, "examples", "scenes", `obstacles-${n}.json`);
  if (!existsSync(f)) {
    console.error(`bench-generate: scene ${f} not found`);
    process.exit(1);
  }
}

const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
};

const work = mkdtempSync(join(tmpdir(), "robwot-bench-"));
const results = {};
const total = robots.length * scenes.length * runs;
let done = 0;
console.log(`bench-generate: ${robots.length} robots x ${scenes.length} scenes x ${runs} runs = ${total} generate processes, ${samples} samples each`);
try {
  for (const robot of robots) {
    results[robot] = {};
    for (const n of scenes) {
      const times = [];
      let last;
      for (let r = 0; r < runs; r++) {
        const out = join(work, `${robot}-${n}-${r}`);
        const args = [cli, "generate", robot, "--scene", join(root, "examples", "scenes", `obstacles-${n}.json`),
          "--samples", String(samples), "--seed", String(r + 1), "--out", out, "--json"];
        if (values.workers) args.push("--workers", values.workers);
        const t0 = performance.now();
        const p = spawnSync(process.execPath, args, { encoding: "utf8", maxBuffer: 64 << 20 });
        const seconds = (performance.now() - t0) / 1000;
        done++;
        if (p.status !== 0) {
          console.error(`bench-generate: ${robot} obstacles-${n} run ${r + 1} failed (exit ${p.status}):\n${p.stderr}`);
          process.exitCode = 1;
          continue;
        }
        last = JSON.parse(p.stdout);
        times.push(seconds);
        rmSync(out, { recursive: true, force: true });
        const st = Object.entries(last.summary.timings).map(([k, v]) => `${k} ${v.toFixed(2)}`).join(", ");
        console.log(`  [${done}/${total}] ${robot} obstacles-${n} run ${r + 1}: ${seconds.toFixed(2)} s ` +
          `(${st}; ${last.summary.collisionFree}/${last.summary.samples} free)`);
      }
      results[robot][n] = {
        times,
        median: times.length ? median(times) : null,
        collisionFree: last?.summary.collisionFree ?? null,
        timings: last?.summary.timings ?? null,
      };
    }
  }
} finally {
  rmSync(work, { recursive: true, force: true });
}

const fmt = (x) => (x === null || x === undefined ? "-" : x.toFixed(1));
const first = scenes[0];
const lastScene = scenes[scenes.length - 1];
const header = ["robot", ...scenes.map((n) => `${n} obst. (s)`), `t(${lastScene})/t(${first})`];
const rows = robots.map((robot) => {
  const cells = scenes.map((n) => fmt(results[robot][n].median));
  const a = results[robot][first].median;
  const b = results[robot][lastScene].median;
  return [robot, ...cells, a && b ? (b / a).toFixed(2) : "-"];
});
const orig = [ORIGINAL.robot, ...scenes.map((n) => fmt(ORIGINAL.seconds[n])), (ORIGINAL.seconds[239] / ORIGINAL.seconds[4]).toFixed(2)];
rows.push(orig);
console.log(`\nMedian wall time of \`robwot generate\` (${samples} samples, ${runs} run(s), backend start included; ` +
  `original: UR3, 80,000 samples):\n`);
console.log(`| ${header.join(" | ")} |`);
console.log(`|${header.map(() => "---").join("|")}|`);
for (const r of rows) console.log(`| ${r.join(" | ")} |`);
if (values.json) writeFileSync(values.json, JSON.stringify({ samples, runs, results }, null, 2));
