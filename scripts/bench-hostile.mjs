#!/usr/bin/env node
/**
 * npm run bench:hostile — what a hostile or broken physical robot costs the twin (issue 34).
 *
 * A stand-in robot (`robwot emulate`) behind a proxy in this process that misbehaves on demand, and a twin
 * (`robwot serve --relay <proxy> --follow`) in its own process, over loopback. Printed:
 * - the twin's resident memory (VmRSS, peak over the case minus before it) while the proxy answers readings
 *   with a body that never ends, answers a relayed move that way, serves an endless TD to a twin starting,
 *   and while a client sends the twin a 300 MB request body;
 * - a hung reading: the time from the first reading held to `physicalState.monitorFault` (this process
 *   polls the twin every 5 ms), and how many of the held episodes made the monitor stop the robot (the stop
 *   reached the proxy), over ROBWOT_BENCH_EPISODES episodes (20) of 1 s each.
 *
 * Environment: ROBWOT_BENCH_EPISODES (20), ROBWOT_BENCH_SECONDS (10, per memory case).
 */
import { spawnSync } from "node:child_process";
import { mkdtempSync, readFileSync, rmSync } from "node:fs";
import { createServer, request } from "node:http";
import { loadavg, tmpdir } from "node:os";
import { join } from "node:path";
import { cli, startCli, stopCli } from "./bench-twin.mjs";

const EPISODES = Number(process.env.ROBWOT_BENCH_EPISODES ?? 20);
const SECONDS = Number(process.env.ROBWOT_BENCH_SECONDS ?? 10);
const MB = 1024 * 1024;
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];


const rss = (pid) => Number(/VmRSS:\s+(\d+) kB/.exec(readFileSync(`/proc/${pid}/status`, "utf8"))?.[1] ?? 0) * 1024;

/** Peak RSS of `pid` above `before` while `during` runs (sampled every 50 ms). */
async function peakWhile(pid, during) {
  const before = rss(pid);
  let peak = before;
  let running = true;
  const sampler = (async () => {
    while (running) {
      peak = Math.max(peak, rss(pid));
      await sleep(50);
    }
  })();
  try {
    await during();
  } finally {
    running = false;
    await sampler;
  }
  return (peak - before) / MB;
}

function endless(res) {
  res.writeHead(200, { "Content-Type": "application/json" });
  res.write("[");
  const chunk = Buffer.from("0,".repeat(32 * 1024));
  const pump = () => {
    while (!res.destroyed && res.write(chunk));
    if (!res.destroyed) res.once("drain", pump);
  };
  pump();
}

/** The proxy in front of the robot: `mode.reading`, `mode.move`, `mode.td` say how to misbehave. */
async function hostileProxy(target) {
  const t = new URL(target);
  const mode = { reading: "forward", move: "forward", td: "forward", stops: 0, held: [] };
  let self = "";
  const server = createServer((req, res) => {
    const chunks = [];
    req.on("data", (c) => chunks.push(c));
    req.on("end", () => {
      const path = req.url ?? "";
      if (/\/actions\/stop$/.test(path)) {
        mode.stops++;
        for (const r of mode.held.splice(0)) r.destroy();
      }
      const reading = /\/properties\/getJointPosition$/.test(path);
      if (reading && mode.reading === "endless") return endless(res);
      if (reading && mode.reading === "hang") return void mode.held.push(res);
      if (/\/actions\/moveTo/.test(path) && mode.move === "endless") return endless(res);
      if (req.method === "GET" && !/\/(properties|actions|events)\//.test(path) && mode.td === "endless") return endless(res);
      const up = request({ host: t.hostname, port: t.port, method: req.method, path, headers: { ...req.headers, host: t.host } }, (answer) => {
        const parts = [];
        answer.on("data", (c) => parts.push(c));
        answer.on("end", () => {
          const headers = { ...answer.headers };
          delete headers["content-length"];
          res.writeHead(answer.statusCode ?? 502, headers);
          res.end(Buffer.concat(parts).toString("utf8").replaceAll(t.origin, self));
        });
      });
      up.on("error", () => res.destroy());
      up.end(Buffer.concat(chunks));
    });
  });
  await new Promise((r) => server.listen(0, "127.0.0.1", r));
  self = `http://127.0.0.1:${server.address().port}`;
  return { url: `${self}${t.pathname}`, mode, close: () => (server.closeAllConnections(), server.close()) };
}

const post = async (url, body) => (await fetch(url, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(body) })).json();

const tmp = mkdtempSync(join(tmpdir(), "robwot-bench-hostile-"));
const folder = join(tmp, "kuka");
const gen = spawnSync(process.execPath, [cli, "generate", "kuka_iiwa", "--samples", "3000", "--out", folder], { stdio: ["ignore", "ignore", "inherit"] });
if (gen.status !== 0) process.exit(gen.status ?? 1);
const { child: robot, info: r } = await startCli(["emulate", folder, "--port", "0"]);
const proxy = await hostileProxy(r.tdUrl);
const rows = [];
const children = [robot];
try {
  const { child: twin, info: s } = await startCli(["serve", folder, "--port", "0", "--realtime", "0", "--relay", proxy.url]);
  children.push(twin);
  const td = s.things[0].tdUrl;
  const state = async () => (await fetch(`${td}/properties/physicalState`)).json();
  while (!(await state()).joints) await sleep(50);
  const startRss = rss(twin.pid) / MB;
  /** the part of an error text that says why (a cap, a deadline) */
  const why = (text) => /(answer (of \d+ bytes )?(is )?larger than \d+( bytes)?|no (complete )?answer within \d+ ms|deadline[^;)]*)/.exec(text ?? "")?.[0] ?? String(text ?? "none").slice(0, 60);

  proxy.mode.reading = "endless";
  rows.push(["endless reading (--follow)", `+${(await peakWhile(twin.pid, () => sleep(SECONDS * 1000))).toFixed(1)} MB`, `lastError: ${why((await state()).lastError)}`]);
  proxy.mode.reading = "forward";

  proxy.mode.move = "endless";
  let relay = null;
  const moved = await peakWhile(twin.pid, async () => {
    const joints = await (await fetch(`${td}/properties/getJointPosition`)).json();
    relay = (await post(`${td}/actions/moveToJointPosition`, { joints: { ...joints, lbr_iiwa_joint_1: 0.3 } })).relay;
  });
  rows.push(["endless answer to a relayed move", `+${moved.toFixed(1)} MB`, `relay: ${relay?.ok ? "ok" : why(relay?.error)}`]);
  proxy.mode.move = "forward";

  let status = 0;
  const body = await peakWhile(twin.pid, async () => {
    const big = Buffer.alloc(300 * MB, 32);
    status = (await fetch(`${td}/actions/stop`, { method: "POST", headers: { "content-type": "application/json" }, body: big }).catch(() => ({ status: "reset" }))).status;
  });
  rows.push(["300 MB request body", `+${body.toFixed(1)} MB`, `answer ${status}`]);

  // hung readings: each episode holds every reading for 1 s while the robot jogs, then lets them through
  const detect = [];
  let stopped = 0;
  for (let e = 0; e < EPISODES; e++) {
    await post(`${r.tdUrl}/actions/jog`, { velocities: { lbr_iiwa_joint_1: e % 2 === 0 ? 0.2 : -0.2 }, duration: 1.5 });
    await sleep(100);
    const stopsBefore = proxy.mode.stops;
    const t0 = performance.now();
    proxy.mode.reading = "hang";
    let seen = null;
    while (performance.now() - t0 < 1_000) {
      if (seen === null && (await state()).monitorFault) seen = performance.now() - t0;
      await sleep(5);
    }
    proxy.mode.reading = "forward";
    for (const held of proxy.mode.held.splice(0)) held.destroy();
    if (seen !== null) detect.push(seen);
    if (proxy.mode.stops > stopsBefore) stopped++;
    while ((await state()).monitorFault) await sleep(20);
  }
  rows.push(["hung reading: fault shown after", detect.length ? `${median(detect).toFixed(0)} ms median` : "never", `${detect.length}/${EPISODES} episodes`]);
  rows.push(["hung reading: robot stopped", `${stopped}/${EPISODES}`, "mode stop (default)"]);
  await stopCli(twin);

  // a twin starting against an endless TD: its relay's TD fetch is cut at the cap, the twin serves anyway
  proxy.mode.td = "endless";
  const late = await startCli(["serve", folder, "--port", "0", "--realtime", "0", "--relay", proxy.url, "--no-follow"]);
  children.push(late.child);
  const lateRss = rss(late.child.pid) / MB;
  rows.push(["endless TD at start (--relay)", `${lateRss.toFixed(0)} MB RSS after start`, `a twin started against a good TD: ${startRss.toFixed(0)} MB`]);
  proxy.mode.td = "forward";
} finally {
  for (const c of children) await stopCli(c);
  proxy.close();
  rmSync(tmp, { recursive: true, force: true });
}
console.log(`robwot hostile-peer bench  node ${process.version}  load average ${loadavg()[0].toFixed(1)}`);
console.log(`KUKA twin relaying to and following an emulated robot behind a misbehaving proxy; memory = the twin's VmRSS peak over the case\n`);
console.log("| case | figure | note |");
console.log("|---|---|---|");
for (const [a, b, c] of rows) console.log(`| ${a} | ${b} | ${c.replaceAll("|", "/")} |`);
