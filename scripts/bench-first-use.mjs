#!/usr/bin/env node
// First use of robots the project never tuned for: `robwot generate` from an empty collision cache (every
// concave collision mesh decomposed), then again with the cache warm, then the fidelity of the labels
// against the exact-mesh reference with the parts just made. Every generation is a full CLI process,
// backend start included; the robots come from example-robot-data (installed with the dev extras).
//
//   npm run bench:first-use                                # Unitree Z1, xArm7, Kinova Jaco 2 (DAE meshes)
//   npm run bench:first-use -- --robots z1 --runs 3 --fidelity-samples 0
//   ROBWOT_PAPER_ROBOTS=/path/to/RobWoT/Assets/URDFs npm run bench:first-use -- --robots paper
//   options: --robots a,b (reference.py names, the paper's robots' names below, or "paper" for all of
//            them whose URDF is there), --runs N (cold runs per robot; median), --samples N,
//            --fidelity-samples N (0: skip; example-robot-data robots only)
//
// The paper's robots (tum-esi/RobWoT, Assets/URDFs; its files are never copied into this repository) come
// with the options a user of each needs: the parallel-linkage arms' couplings (README "The paper's robots").
import { spawnSync } from "node:child_process";
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { loadavg, tmpdir } from "node:os";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { parseArgs } from "node:util";

const root = join(dirname(fileURLToPath(import.meta.url)), "..");
const cli = join(root, "packages", "cli", "dist", "main.js");
const python = join(root, "sim-backend", ".venv", "bin", "python");
const { values } = parseArgs({
  options: {
    robots: { type: "string", default: "z1,xarm7,kinova" },
    runs: { type: "string", default: "1" },
    samples: { type: "string", default: "20000" },
    "fidelity-samples": { type: "string", default: "20000" },
  },
});
/** The paper's robots: URDF under $ROBWOT_PAPER_ROBOTS and the generate options each needs. */
const UARM_BARS = ["Joint4=-Joint2", "Joint5=Joint2", "Joint6=Joint2+Joint3", "Joint7=-Joint3", "Joint9=Joint2+Joint3"];
const PAPER = {
  ur3: { urdf: "ur_description/urdf/ur3_robot.urdf", args: [] },
  ur10: { urdf: "ur_description/urdf/ur10_robot.urdf", args: [] },
  cr3: { urdf: "cr_description/urdf/cr3_robot.urdf", args: [] },
  cr5: { urdf: "cr_description/urdf/cr5_robot.urdf", args: [] },
  cr10: { urdf: "cr_description/urdf/cr10_robot.urdf", args: [] },
  cr16: { urdf: "cr_description/urdf/cr16_robot.urdf", args: [] },
  "dobot-magician": { urdf: "dobot_description/urdf/dobot_magician.urdf", args: ["--keep-level", "dobot1/link_4"] },
  "uarm-swift-pro": { urdf: "swiftpro/urdf/swiftpro.urdf", args: ["--keep-level", "Link8", ...UARM_BARS.flatMap((c) => ["--couple", c])] },
  "mycobot-280": { urdf: "mycobot_description/urdf/mycobot.urdf", args: [] },
  "mycobot-pro": { urdf: "mycobotPro_description/urdf/mycobotPro.urdf", args: [] },
  mecharm: { urdf: "mecharm_description/urdf/mecharm.urdf", args: [] },
  "mypal-260": { urdf: "mypal_description/urdf/mypal_260.urdf", args: [] },
  "m1-pro": { urdf: "m1pro_description/urdf/m1pro_description.urdf", args: [] },
};
const paperDir = process.env.ROBWOT_PAPER_ROBOTS;
const paperNames = Object.keys(PAPER).filter((n) => paperDir !== undefined && existsSync(join(paperDir, PAPER[n].urdf)));
const robots = values.robots.split(",").filter(Boolean).flatMap((n) => (n === "paper" ? paperNames : [n]));
if (robots.some((n) => n in PAPER) && paperDir === undefined) {
  console.error("bench-first-use: the paper's robots need ROBWOT_PAPER_ROBOTS=<a RobWoT checkout>/Assets/URDFs");
  process.exit(1);
}
const runs = Number(values.runs);
if (!existsSync(cli)) {
  console.error(`bench-first-use: ${cli} not found: run npm run build first`);
  process.exit(1);
}

/** URDF, package roots and options of a robot: one of the paper's, or of example-robot-data as the
 * fidelity reference names them. */
function robotFiles(name) {
  if (name in PAPER) return { urdf: join(paperDir, PAPER[name].urdf), roots: {}, args: PAPER[name].args };
  const code = `import json; from robwot_bench.reference import example_robot as e; r = e(${JSON.stringify(name)}); ` +
    "print(json.dumps({'urdf': str(r.urdf), 'roots': r.package_roots, 'args': []}))";
  const out = spawnSync(python, ["-c", code], { encoding: "utf8" });
  if (out.status !== 0) throw new Error(`robot ${name}: ${out.stderr.trim().split("\n").at(-1)}`);
  return JSON.parse(out.stdout);
}

const median = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
};

/** One `robwot generate` process: wall seconds and the per-mesh lines it printed; `refused`: generate's
 * last error line when it failed (a robot whose files are incomplete is a row of the table, not the end). */
function generate(files, cache, out) {
  const roots = Object.entries(files.roots).flatMap(([k, v]) => ["--package-root", `${k}=${v}`]);
  const t0 = performance.now();
  const r = spawnSync(process.execPath, [cli, "generate", files.urdf, ...roots, ...files.args, "--samples", values.samples, "--out", out, "--force"], {
    encoding: "utf8",
    env: { ...process.env, ROBWOT_COLLISION_CACHE: cache },
  });
  const seconds = (performance.now() - t0) / 1000;
  if (r.status !== 0) {
    const error = r.stderr.split("\n").filter((l) => l.startsWith("robwot: error:")).at(-1);
    return { seconds, meshes: [], refused: error?.slice("robwot: error: ".length) ?? `exit ${r.status}` };
  }
  const meshes = [...r.stderr.matchAll(/decompose (\d+)\/(\d+)(?:, ETA [^:]+)?: (\S+) \((convex, kept|(\d+) convex parts), ([\d.]+m?[\d.]*s)\)/g)].map((m) => ({
    mesh: m[3],
    parts: m[5] === undefined ? 0 : Number(m[5]),
    time: m[6],
  }));
  return { seconds, meshes };
}

const work = mkdtempSync(join(tmpdir(), "robwot-first-use-"));
const load = loadavg().map((x) => x.toFixed(2)).join(" ");
console.log(`bench-first-use: ${robots.join(", ")}; ${values.samples} samples; ${runs} cold run(s) each; load average ${load}`);
const rows = [];
try {
  for (const name of robots) {
    const files = robotFiles(name);
    const cold = [];
    let meshes = [];
    let refused;
    for (let i = 0; i < runs; i++) {
      const cache = join(work, `${name}-cache-${i}`);
      const run = generate(files, cache, join(work, `${name}-twin`));
      if (run.refused !== undefined) {
        refused = run.refused;
        break;
      }
      cold.push(run.seconds);
      meshes = run.meshes;
      if (i < runs - 1) rmSync(cache, { recursive: true, force: true });
    }
    if (refused !== undefined) {
      rows.push({ name, refused });
      console.log(`\n${name}: refused: ${refused}`);
      continue;
    }
    const warm = generate(files, join(work, `${name}-cache-${runs - 1}`), join(work, `${name}-twin`));
    rows.push({ name, cold: median(cold), warm: warm.seconds, meshes, cache: join(work, `${name}-cache-${runs - 1}`) });
    console.log(`\n${name}: first twin ${median(cold).toFixed(1)} s (runs: ${cold.map((s) => s.toFixed(1)).join(", ")}), cached ${warm.seconds.toFixed(1)} s`);
    console.log(`  ${"mesh".padEnd(30)}${"parts".padStart(6)}${"time".padStart(8)}  (as each finished; two at a time on 2 cores)`);
    for (const m of meshes) console.log(`  ${m.mesh.padEnd(30)}${String(m.parts).padStart(6)}${m.time.padStart(8)}`);
  }
  console.log(`\n${"robot".padEnd(16)}${"new meshes".padStart(11)}${"concave".padStart(9)}${"first twin (s)".padStart(16)}${"cached (s)".padStart(12)}`);
  for (const r of rows) {
    if (r.refused !== undefined) {
      console.log(`${r.name.padEnd(16)}  refused (${r.refused.slice(0, 60)})`);
      continue;
    }
    console.log(`${r.name.padEnd(16)}${String(r.meshes.length).padStart(11)}${String(r.meshes.filter((m) => m.parts > 0).length).padStart(9)}${r.cold.toFixed(1).padStart(16)}${r.warm.toFixed(1).padStart(12)}`);
  }
  if (Number(values["fidelity-samples"]) > 0) {
    for (const r of rows.filter((row) => !(row.name in PAPER) && row.refused === undefined)) {
      console.log("");
      const f = spawnSync(python, ["-m", "robwot_bench.fidelity", "--robots", r.name, "--samples", values["fidelity-samples"], "--targets", "0", "--grazes", "0"], {
        encoding: "utf8",
        env: { ...process.env, ROBWOT_COLLISION_CACHE: r.cache },
      });
      if (f.status !== 0) throw new Error(`fidelity ${r.name} failed:\n${f.stderr}`);
      process.stdout.write(f.stdout.split("\n\n")[0] + "\n");
    }
  }
} finally {
  rmSync(work, { recursive: true, force: true });
}
