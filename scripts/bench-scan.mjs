/**
 * `npm run bench:scan`: first `python -m robwot_bench.scan` (a ~200,000-point cloud to a scene, in process,
 * per cover), then the live part: a KUKA twin served by `robwot serve --scan-source FOLDER`, a real cell
 * (examples/scenes/table.json in a backend of its own) whose box is moved --runs times; each time the
 * backend's depth camera takes a frame (320 x 240) that is renamed into the folder, and the time from the
 * rename to the /live `scene` message showing the box where it now is is measured. Prints each run, the
 * median and p95, and the load average.
 *
 *   npm run bench:scan [-- --runs 10]
 */
import { spawnSync } from "node:child_process";
import { mkdirSync, mkdtempSync, renameSync, rmSync } from "node:fs";
import { loadavg, tmpdir } from "node:os";
import { join } from "node:path";
import { performance } from "node:perf_hooks";
import WebSocket from "ws";
import { launchBackend } from "../packages/sim-client/dist/index.js";
import { cli, repo, startCli } from "./bench-twin.mjs";

const runsAt = process.argv.indexOf("--runs");
const runs = runsAt >= 0 ? Number(process.argv[runsAt + 1]) : 10;
if (!Number.isInteger(runs) || runs < 1 || runs > 100) {
  console.error("usage: npm run bench:scan [-- --runs 1..100]");
  process.exit(2);
}
const py = spawnSync(join(repo, "sim-backend", ".venv", "bin", "python"), ["-m", "robwot_bench.scan"], { stdio: "inherit" });
if (py.status !== 0) process.exit(py.status ?? 1);

const tmp = mkdtempSync(join(tmpdir(), "robwot-bench-scan-"));
const frames = join(tmp, "frames");
mkdirSync(frames);
const gen = spawnSync(process.execPath, [cli, "generate", "kuka_iiwa", "--samples", "3000", "--out", join(tmp, "kuka")], { encoding: "utf8" });
if (gen.status !== 0) {
  console.error(gen.stderr);
  process.exit(gen.status ?? 1);
}
const cell = await launchBackend();
await cell.client.loadScene({ path: join(repo, "examples", "scenes", "table.json") });
const { child, info } = await startCli(["serve", join(tmp, "kuka"), "--port", "0", "--realtime", "0", "--scan-source", frames, "--scan-noise", "0.004"]);
const slug = info.things[0].slug;
const ws = new WebSocket(`${info.liveUrl}?thing=${slug}`);
const waiters = [];
ws.on("message", (d) => {
  const m = JSON.parse(d.toString());
  for (const w of [...waiters]) {
    if (!w.pred(m)) continue;
    waiters.splice(waiters.indexOf(w), 1);
    w.resolve(performance.now());
  }
});
await new Promise((r) => ws.once("open", r));
const seen = (x, y) => new Promise((resolve) => waiters.push({ resolve, pred: (m) => m.type === "scene" && m.obstacles.some((o) => o.name.startsWith("scan-") && Math.hypot(o.position[0] - x, o.position[1] - y) < 0.03) }));

let frameNo = 0;
async function frame() {
  const file = join(tmp, `frame${++frameNo}.ply`);
  await cell.client.captureDepth({ file, position: [1.5, 0.2, 1.3], target: [0.4, 0, 0], noise: 0.0003, dropout: 0.02, seed: frameNo });
  return file;
}
const latencies = [];
try {
  const first = seen(0.55, 0.25);
  renameSync(await frame(), join(frames, `frame${frameNo}.ply`));
  await first;
  console.log("\n| run | box moved to (m) | frame to /live scene (ms) |");
  console.log("|---|---|---|");
  for (let k = 1; k <= runs; k++) {
    const [x, y] = k % 2 ? [0.6, -0.05] : [0.55, 0.25];
    await cell.client.moveObstacle({ name: "box", position: [x, y, 0.09] });
    const file = await frame();
    const shown = seen(x, y);
    const t0 = performance.now();
    renameSync(file, join(frames, `frame${frameNo}.ply`));
    const ms = (await shown) - t0;
    latencies.push(ms);
    console.log(`| ${k} | ${x}, ${y} | ${ms.toFixed(0)} |`);
  }
} finally {
  ws.close();
  child.kill("SIGINT");
  await new Promise((r) => child.once("exit", r));
  await cell.stop();
  rmSync(tmp, { recursive: true, force: true });
}
latencies.sort((a, b) => a - b);
const pick = (q) => latencies[Math.min(latencies.length - 1, Math.max(0, Math.round(q * latencies.length) - 1))];
console.log(`\nmoved box seen by the twin: median ${pick(0.5).toFixed(0)} ms, p95 ${pick(0.95).toFixed(0)} ms over ${latencies.length} frames; load average ${loadavg().map((v) => v.toFixed(2)).join(" ")}\n`);
