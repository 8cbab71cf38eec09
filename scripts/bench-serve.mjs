#!/usr/bin/env node
/**
 * `npm run bench:serve`: the servient's HTTP performance on this machine.
 * - property read (getJointPosition) latency p50/p99 and reads/s with 1 and 16 concurrent clients
 * - moveToCartesianPosition round trip at realtime 0 (validation + IK + path check + motion + FK)
 * - validateCartesianPosition on uniform random targets in the TD's input bounds, 4 clients (the
 *   workload of tests/serve-offline.test.ts: most targets are unreachable or need other IK solutions)
 * - validateCartesianPosition, one client, of targets within 5 cm of the end effector that the twin
 *   reaches by a straight collision-free path (only those answers are timed: the verdict of a plain move)
 * Twin: `robwot generate kuka_iiwa --samples 3000` into a temp folder (or ROBWOT_BENCH_TWIN=<folder>),
 * served by `robwot serve --port 0 --realtime 0` in its own process (the load generator is this one).
 * Prints a table. Options: --reads N (default 4000), --moves N (default 30), --validations N (default 400).
 */
import { Agent, request } from "node:http";
import { serveBenchTwin } from "./bench-twin.mjs";

const arg = (name, def) => {
  const i = process.argv.indexOf(`--${name}`);
  return i > 0 ? Number(process.argv[i + 1]) : def;
};
const READS = arg("reads", 4000);
const MOVES = arg("moves", 30);
const VALIDATIONS = arg("validations", 400);

const served = await serveBenchTwin("serve", 3000);
const info = served.info;
const base = new URL(info.things[0].tdUrl);
const agent = new Agent({ keepAlive: true, maxSockets: 64 });

function call(method, path, body) {
  return new Promise((resolve, reject) => {
    const data = body === undefined ? undefined : Buffer.from(JSON.stringify(body));
    const req = request(
      { host: base.hostname, port: base.port, path, method, agent, headers: data ? { "content-type": "application/json", "content-length": data.length } : {} },
      (res) => {
        const chunks = [];
        res.on("data", (c) => chunks.push(c));
        res.on("end", () => resolve({ status: res.statusCode, body: Buffer.concat(chunks).toString() }));
      },
    );
    req.on("error", reject);
    req.end(data);
  });
}

const pct = (xs, p) => {
  const a = [...xs].sort((x, y) => x - y);
  return a[Math.min(a.length - 1, Math.floor((p / 100) * a.length))];
};

/** `total` calls of `request()` (resolving to its HTTP response) spread over `clients` concurrent loops. */
async function timed(what, total, clients, request, keep = () => true) {
  const lat = [];
  let left = total;
  const t0 = performance.now();
  await Promise.all(
    Array.from({ length: clients }, async () => {
      while (left-- > 0) {
        const t = performance.now();
        const r = await request();
        if (r.status !== 200) throw new Error(`${what} answered ${r.status}: ${r.body}`);
        if (keep(r)) lat.push(performance.now() - t);
      }
    }),
  );
  const secs = (performance.now() - t0) / 1000;
  return { what, n: lat.length, p50: pct(lat, 50), p95: pct(lat, 95), p99: pct(lat, 99), rate: lat.length / secs };
}

async function reads(clients) {
  const path = `${base.pathname}/properties/getJointPosition`;
  for (let i = 0; i < 200; i++) await call("GET", path); // warm-up
  return timed(`property read, ${clients} client${clients > 1 ? "s" : ""}`, READS, clients, () => call("GET", path));
}

async function moves() {
  const targets = [
    { x: 0.45, y: 0.1, z: 0.6 },
    { x: 0.35, y: -0.25, z: 0.7 },
  ];
  let i = 0;
  return timed("moveToCartesianPosition, realtime 0", MOVES, 1, () =>
    call("POST", `${base.pathname}/actions/moveToCartesianPosition`, targets[i++ % 2]),
  );
}

async function validations(clients) {
  const td = JSON.parse((await call("GET", base.pathname)).body);
  const input = td.actions.validateCartesianPosition.input.properties;
  let seed = 2024; // the same deterministic stream for every run
  const u = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
  const target = () => Object.fromEntries(["x", "y", "z"].map((k) => [k, input[k].minimum + u() * (input[k].maximum - input[k].minimum)]));
  return timed(`validateCartesianPosition, random targets, ${clients} clients`, VALIDATIONS, clients, () =>
    call("POST", `${base.pathname}/actions/validateCartesianPosition`, target()),
  );
}

async function straightValidations() {
  const p = JSON.parse((await call("GET", `${base.pathname}/properties/getCartesianPosition`)).body);
  let seed = 7;
  const u = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
  const straight = (r) => {
    const b = JSON.parse(r.body);
    return b.valid === true && b.checks?.path?.planned === "straight";
  };
  return timed(
    "validateCartesianPosition, straight free path, 1 client",
    VALIDATIONS,
    1,
    () => call("POST", `${base.pathname}/actions/validateCartesianPosition`, { x: p.x + (u() - 0.5) * 0.1, y: p.y + (u() - 0.5) * 0.1, z: p.z + (u() - 0.5) * 0.1 }),
    straight,
  );
}

try {
  const rows = [await reads(1), await reads(16), await moves(), await validations(4), await straightValidations()];
  const head = ["measurement", "n", "p50 ms", "p95 ms", "p99 ms", "per s"];
  const cells = rows.map((r) => [r.what, String(r.n), r.p50.toFixed(2), r.p95.toFixed(2), r.p99.toFixed(2), r.rate.toFixed(0)]);
  const w = head.map((h, i) => Math.max(h.length, ...cells.map((c) => c[i].length)));
  const line = (c) => `| ${c.map((x, i) => (i === 0 ? x.padEnd(w[i]) : x.padStart(w[i]))).join(" | ")} |`;
  console.log(line(head));
  console.log(`|${w.map((n, i) => (i === 0 ? "-".repeat(n + 2) : `${"-".repeat(n + 1)}:`)).join("|")}|`);
  for (const c of cells) console.log(line(c));
} finally {
  agent.destroy();
  await served.stop();
}
