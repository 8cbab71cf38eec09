#!/usr/bin/env node
/**
 * npm run bench:slow-clients — the servient's memory with clients that never read (issue 21).
 *
 * A KUKA twin served in its own process (scripts/bench-twin.mjs); OBSTACLES obstacles with long names are
 * added (each scene frame is then large), the load below runs 5 s without clients (the heap grows to
 * what the load itself needs) and the servient's idle RSS is taken. Then CLIENTS raw TCP
 * clients connect and never read a byte (half /live WebSocket upgrades, half SSE streams of the joint
 * position), one ordinary /live client reads everything, and for SECONDS the obstacles are moved
 * round-robin while the robot moves back and forth (joint frames at the backend's full rate). The
 * servient's RSS (VmRSS of its process, Python backend excluded) is sampled every 250 ms. With
 * ROBWOT_BENCH_GC=1 every figure is taken after a full garbage collection asked through the servient's
 * inspector, every 2 s during the load: what the servient holds, without the garbage V8 has not collected
 * yet (the plain peak varies with V8's schedule from run to run). At the end
 * every silent client reads what it was sent: "disconnected" counts those whose connection the servient
 * ended, "the reason read by" those that still received the close frame (1008) or the SSE
 * `: disconnected:` comment (a connection cut for being slow is destroyed 30 s after its close: a client
 * that reads only later finds a reset connection). An SSE client is cut only once the kernel's socket
 * buffers, which take megabytes of small joint messages, are full.
 *
 * Environment: ROBWOT_BENCH_SECONDS (60), ROBWOT_BENCH_CLIENTS (100), ROBWOT_BENCH_OBSTACLES (200),
 * ROBWOT_BENCH_TWIN (a twin folder instead of generating one), ROBWOT_BENCH_MAX_RSS_MB (2000: the load
 * stops early above it, so an unbounded servient cannot take the machine down), ROBWOT_BENCH_GC (0).
 */
import { randomBytes } from "node:crypto";
import { readdirSync, readFileSync, readlinkSync } from "node:fs";
import { connect } from "node:net";
import { loadavg } from "node:os";
import WebSocket from "ws";
import { serveBenchTwin } from "./bench-twin.mjs";

const SECONDS = Number(process.env.ROBWOT_BENCH_SECONDS ?? 60);
const CLIENTS = Number(process.env.ROBWOT_BENCH_CLIENTS ?? 100);
const OBSTACLES = Number(process.env.ROBWOT_BENCH_OBSTACLES ?? 200);
const MAX_RSS_MB = Number(process.env.ROBWOT_BENCH_MAX_RSS_MB ?? 2000);
const AFTER_GC = process.env.ROBWOT_BENCH_GC === "1";

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const mb = (kb) => (kb / 1024).toFixed(1);

/** The `robwot serve` process among this process's children (bench-twin spawns it). */
function servePid() {
  for (const name of readdirSync("/proc").filter((n) => /^\d+$/.test(n))) {
    try {
      const stat = readFileSync(`/proc/${name}/stat`, "utf8");
      const ppid = Number(stat.slice(stat.lastIndexOf(")") + 2).split(" ")[1]);
      if (ppid === process.pid && readFileSync(`/proc/${name}/cmdline`, "utf8").includes("serve")) return Number(name);
    } catch {
      /* gone meanwhile */
    }
  }
  throw new Error("robwot serve process not found");
}

/** The ports `pid` listens on (its socket inodes among the LISTEN entries of /proc/net/tcp). */
function listeningPorts(pid) {
  const inodes = new Set();
  for (const fd of readdirSync(`/proc/${pid}/fd`)) {
    try {
      const m = /^socket:\[(\d+)\]$/.exec(readlinkSync(`/proc/${pid}/fd/${fd}`));
      if (m) inodes.add(m[1]);
    } catch {
      /* closed meanwhile */
    }
  }
  return readFileSync("/proc/net/tcp", "utf8")
    .split("\n")
    .slice(1)
    .map((l) => l.trim().split(/\s+/))
    .filter((f) => f[3] === "0A" && inodes.has(f[9]))
    .map((f) => parseInt(f[1].split(":")[1], 16));
}

/** A full garbage collection in `pid` through its inspector (Chrome DevTools protocol); resolves when done. */
async function inspectorGc(pid, httpPort) {
  let url = null;
  for (const port of listeningPorts(pid).filter((p) => p !== httpPort)) {
    const list = await fetch(`http://127.0.0.1:${port}/json/list`).then((r) => r.json(), () => null);
    url ??= list?.[0]?.webSocketDebuggerUrl ?? null;
  }
  if (!url) throw new Error(`no inspector found in process ${pid}`);
  const ws = new WebSocket(url);
  await new Promise((r, j) => (ws.once("open", r), ws.once("error", j)));
  let id = 0;
  return {
    gc: () =>
      new Promise((resolve) => {
        const mine = ++id;
        const onMessage = (d) => {
          if (JSON.parse(d.toString()).id !== mine) return;
          ws.off("message", onMessage);
          resolve();
        };
        ws.on("message", onMessage);
        ws.send(JSON.stringify({ id: mine, method: "HeapProfiler.collectGarbage" }));
      }),
    close: () => ws.close(),
  };
}

const rssKb = (pid) => Number(/VmRSS:\s+(\d+)/.exec(readFileSync(`/proc/${pid}/status`, "utf8"))?.[1] ?? NaN);

async function post(base, action, body) {
  const r = await fetch(`${base}/actions/${action}`, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify(body) });
  const text = await r.text();
  if (r.status >= 400) throw new Error(`${action}: ${r.status} ${text.slice(0, 200)}`);
  return text;
}

/** A client that sends its request and then never reads (its socket paused from the first moment). */
function silentClient(port, path, websocket) {
  return new Promise((resolve, reject) => {
    const socket = connect(port, "127.0.0.1", () => {
      const ws = websocket
        ? `Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: ${randomBytes(16).toString("base64")}\r\nSec-WebSocket-Version: 13\r\n`
        : "Accept: text/event-stream\r\n";
      socket.write(`GET ${path} HTTP/1.1\r\nHost: 127.0.0.1:${port}\r\n${ws}\r\n`);
      socket.pause();
      resolve({ socket, websocket });
    });
    socket.once("error", reject);
  });
}

/** Reads what a silent client was sent; whether the servient ended it, and whether it said why. */
function drain(client, ms) {
  const { socket, websocket } = client;
  return new Promise((resolve) => {
    const chunks = [];
    let ended = false;
    const done = () => {
      clearTimeout(timer);
      socket.destroy();
      const all = Buffer.concat(chunks);
      // a close frame: FIN + opcode 8, then the status code 1008 (JSON text never holds byte 0x88)
      const at = all.indexOf(0x88);
      const reason = websocket ? at >= 0 && all.readUInt16BE(at + 2) === 1008 : all.includes(": disconnected:");
      resolve({ ended: ended || reason, reason });
    };
    const timer = setTimeout(done, ms);
    socket.on("data", (d) => chunks.push(d));
    socket.once("end", () => ((ended = true), done()));
    socket.once("error", () => ((ended = true), done()));
    socket.resume();
  });
}

// with ROBWOT_BENCH_GC=1 the served twin's process opens its inspector on a free port
const nodeOptions = process.env.NODE_OPTIONS;
if (AFTER_GC) process.env.NODE_OPTIONS = `${nodeOptions ?? ""} --inspect=127.0.0.1:0`.trim();
const served = await serveBenchTwin("slow-clients", 3000);
if (nodeOptions === undefined) delete process.env.NODE_OPTIONS;
else process.env.NODE_OPTIONS = nodeOptions;
const { url, liveUrl } = served.info;
const slug = served.info.things[0].slug;
const base = `${url}/${slug}`;
const port = Number(new URL(url).port);
const pid = servePid();
const inspector = AFTER_GC ? await inspectorGc(pid, port) : null;
/** RSS now, or after a full garbage collection with ROBWOT_BENCH_GC=1 */
const measure = async () => (await inspector?.gc(), rssKb(pid));
const joints = Array.from({ length: 7 }, (_, i) => `lbr_iiwa_joint_${i + 1}`);
const pose = (j1) => Object.fromEntries(joints.map((n, i) => [n, i === 0 ? j1 : i === 3 ? -0.6 : 0]));

try {
  // obstacles far from the robot (nothing collides), names long enough to make each scene frame large
  const names = Array.from({ length: OBSTACLES }, (_, i) => `bench-obstacle-${String(i).padStart(4, "0")}-${"x".repeat(120)}`);
  const spot = (i, t) => [3 + (i % 20) * 0.3, -3 + Math.floor(i / 20) * 0.3, 0.1 + 0.05 * Math.sin(t + i)];
  for (const [i, name] of names.entries()) await post(base, "addObstacle", { name, shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: spot(i, 0) });
  const start = rssKb(pid);

  /** Moves the obstacles round-robin (two lanes) and the robot back and forth while `running()`. */
  const stats = { sceneChanges: 0, moves: 0, last: null };
  const load = async (running) => {
    const lane = async (first) => {
      for (let k = first; running(); k += 2) {
        const i = k % names.length;
        stats.last = { name: names[i], position: spot(i, k / 10) };
        await post(base, "moveObstacle", stats.last);
        stats.sceneChanges++;
      }
    };
    const motion = async () => {
      for (let k = 0; running(); k++) {
        await post(base, "moveToJointPosition", { joints: pose(k % 2 ? 0.5 : -0.5) });
        stats.moves++;
      }
    };
    await Promise.all([lane(0), lane(1), motion()]);
  };
  // the same load without clients first: the heap grows to what the load itself needs
  const warm = Date.now() + 5000;
  await load(() => Date.now() < warm);
  await sleep(2000);
  const idleSamples = [];
  for (let i = 0; i < 12; i++, await sleep(250)) idleSamples.push(await measure());
  const idle = idleSamples.sort((a, b) => a - b)[idleSamples.length >> 1];

  const clients = [];
  for (let i = 0; i < CLIENTS; i++) {
    const websocket = i % 2 === 0;
    const path = websocket ? `/live?thing=${encodeURIComponent(slug)}` : `/${slug}/properties/getJointPosition/sse`;
    clients.push(await silentClient(port, path, websocket));
  }
  const reader = new WebSocket(liveUrl, { headers: {} });
  let lastScene = null;
  reader.on("message", (d) => {
    const m = JSON.parse(d.toString());
    if (m.type === "scene") lastScene = m;
  });
  await new Promise((r, j) => (reader.once("open", r), reader.once("error", j)));
  reader.send(JSON.stringify({ subscribe: slug }));

  let peak = idle;
  let stoppedEarly = false;
  let stoppedAfter = 0;
  const end = Date.now() + SECONDS * 1000;
  const running = () => Date.now() < end && !stoppedEarly;
  const sampler = setInterval(() => {
    const kb = rssKb(pid);
    if (!AFTER_GC) peak = Math.max(peak, kb);
    if (kb / 1024 > MAX_RSS_MB && !stoppedEarly) {
      stoppedEarly = true;
      stoppedAfter = (Date.now() - (end - SECONDS * 1000)) / 1000;
    }
  }, 250);
  const gcSampling = (async () => {
    while (AFTER_GC && running()) {
      await sleep(2000);
      peak = Math.max(peak, await measure());
    }
  })();
  stats.sceneChanges = stats.moves = 0;
  await load(running);
  await gcSampling;
  clearInterval(sampler);
  await sleep(2000);
  const final = await measure();
  inspector?.close();
  const latestSeen = lastScene?.obstacles.some((o) => o.name === stats.last?.name && o.position.every((v, i) => Math.abs(v - stats.last.position[i]) < 1e-9)) ?? false;
  reader.close();
  const outcomes = await Promise.all(clients.map((c) => drain(c, 5000)));

  const gcNote = AFTER_GC ? ", after a full GC" : "";
  const loadAvg = loadavg().map((l) => l.toFixed(2)).join(" ");
  const rows = [
    ["clients (never reading)", `${CLIENTS} (${Math.ceil(CLIENTS / 2)} /live, ${Math.floor(CLIENTS / 2)} SSE)`],
    ["obstacles / scene frame", `${OBSTACLES} / ${(Buffer.byteLength(JSON.stringify(lastScene ?? {})) / 1024).toFixed(1)} KiB`],
    ["duration", stoppedEarly ? `stopped after ${stoppedAfter.toFixed(1)} s of ${SECONDS} s: RSS above ${MAX_RSS_MB} MB` : `${SECONDS} s`],
    ["scene changes / moves", `${stats.sceneChanges} / ${stats.moves}`],
    ["RSS with the scene loaded", `${mb(start)} MB`],
    [`idle RSS (after 5 s of the load alone${gcNote})`, `${mb(idle)} MB`],
    [`peak RSS${gcNote}`, `${mb(peak)} MB`],
    [`final RSS${gcNote}`, `${mb(final)} MB`],
    ["peak - idle", `${mb(peak - idle)} MB`],
    ...[true, false].map((websocket) => {
      const of = outcomes.filter((_, i) => clients[i].websocket === websocket);
      const reason = of.filter((o) => o.reason).length;
      return [`${websocket ? "/live" : "SSE"} clients disconnected`, `${of.filter((o) => o.ended).length} of ${of.length} (the reason read by ${reason})`];
    }),
    ["reading client has the latest scene", latestSeen ? "yes" : "no"],
    ["load average (1/5/15 min)", loadAvg],
  ];
  const w = Math.max(...rows.map(([k]) => k.length));
  console.log(`\nbench:slow-clients (servient pid ${pid}, node ${process.version})`);
  for (const [k, v] of rows) console.log(`  ${k.padEnd(w)}  ${v}`);
} finally {
  await served.stop();
}
