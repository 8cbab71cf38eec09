#!/usr/bin/env node
/**
 * npm run bench:follow — how far the twin's mirrored state lags the physical robot (issue 25).
 *
 * A stand-in robot (`robwot emulate`, no latency, lag or noise) and a twin serving the same KUKA folder
 * with `--follow` at its TD, each in its own process, over loopback. The robot jogs joint 1 at a constant
 * VELOCITY; meanwhile this process reads the twin's `physicalState` every 20 ms. At a read taken at time t
 * (this process's clock) the robot was truly at v x (t - t0), t0 when the jog was sent; the twin shows
 * q: its lag behind the robot is t - t0 - q / v (the polling period, the read of the robot's Thing, the
 * servient's answer). Printed per follow rate: median, p95 and largest lag. The figure includes the time
 * the jog command takes to reach the robot (it only makes the robot later, so the lag larger).
 *
 * Environment: ROBWOT_BENCH_SECONDS (4, per rate), ROBWOT_BENCH_RATES ("30,50,100").
 */
import { spawnSync } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { loadavg, tmpdir } from "node:os";
import { join } from "node:path";
import { cli, startCli, stopCli } from "./bench-twin.mjs";

const SECONDS = Number(process.env.ROBWOT_BENCH_SECONDS ?? 4);
const RATES = (process.env.ROBWOT_BENCH_RATES ?? "30,50,100").split(",").map(Number);
const VELOCITY = 0.5;
const J1 = "lbr_iiwa_joint_1";

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));


async function post(url, body) {
  const r = await fetch(url, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(body) });
  return r.json();
}

const pct = (xs, p) => [...xs].sort((a, b) => a - b)[Math.min(xs.length - 1, Math.floor((p / 100) * xs.length))];

const tmp = mkdtempSync(join(tmpdir(), "robwot-bench-follow-"));
const twin = join(tmp, "kuka");
const gen = spawnSync(process.execPath, [cli, "generate", "kuka_iiwa", "--samples", "3000", "--out", twin], { stdio: ["ignore", "ignore", "inherit"] });
if (gen.status !== 0) process.exit(gen.status ?? 1);
const { child: robot, info: r } = await startCli(["emulate", twin, "--port", "0"]);
const rows = [];
try {
  for (const rate of RATES) {
    const { child: server, info: s } = await startCli(["serve", twin, "--port", "0", "--realtime", "0", "--follow", r.tdUrl, "--follow-rate", String(rate)]);
    try {
      const td = s.things[0].tdUrl;
      const joints = await (await fetch(`${r.tdUrl}/properties/getJointPosition`)).json();
      await post(`${r.tdUrl}/actions/moveToJointPosition`, { joints: { ...joints, [J1]: -1 }, speed: 0.5 });
      await sleep(500);
      const from = -1;
      const t0 = performance.now();
      const jog = post(`${r.tdUrl}/actions/jog`, { velocities: { [J1]: VELOCITY }, duration: SECONDS + 0.5 });
      const lags = [];
      await sleep(300); // past the start: the twin has seen the robot moving
      while ((performance.now() - t0) / 1000 < SECONDS) {
        const t = (performance.now() - t0) / 1000;
        const st = await (await fetch(`${td}/properties/physicalState`)).json();
        const q = st.joints?.[J1];
        if (typeof q === "number") lags.push(t - (q - from) / VELOCITY);
        await sleep(20);
      }
      await jog;
      rows.push({ rate, n: lags.length, p50: pct(lags, 50), p95: pct(lags, 95), max: Math.max(...lags) });
    } finally {
      await stopCli(server);
    }
  }
} finally {
  await stopCli(robot);
  rmSync(tmp, { recursive: true, force: true });
}
console.log(`robwot follow bench  node ${process.version}  load average ${loadavg()[0].toFixed(1)}`);
console.log(`joint 1 jogged at ${VELOCITY} rad/s for ${SECONDS} s per rate; the twin's physicalState read every 20 ms over loopback\n`);
console.log("| follow rate | reads | lag median | lag p95 | lag max |");
console.log("|---|---|---|---|---|");
for (const x of rows) console.log(`| ${x.rate} Hz | ${x.n} | ${(x.p50 * 1000).toFixed(0)} ms | ${(x.p95 * 1000).toFixed(0)} ms | ${(x.max * 1000).toFixed(0)} ms |`);
