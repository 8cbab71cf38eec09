#!/usr/bin/env node
/**
 * `npm run bench:fuzz`: a bounded Schemathesis run against a live twin, from the OpenAPI document that
 * `robwot openapi` writes. Twin: `robwot generate kuka_iiwa --samples 2000` into a temp folder (or
 * ROBWOT_BENCH_TWIN=<folder>), served by `robwot serve --port 0 --realtime 0` (moves are simulated: the
 * fuzzer may call them). Checks: not_a_server_error, response_schema_conformance,
 * status_code_conformance, content_type_conformance. Not fuzzed: the long-poll routes
 * (`.../observable`, `.../sse`, `events/...`), which answer only on the next change.
 * Prints one row per operation (requests, answers by status class, 5xx) and the failures by check.
 * Then Schemathesis's stateful phase on its own (--stateful-examples N, default 50): it follows the
 * OpenAPI links of an asynchronous move's 201 to its queryaction / cancelaction operations; counted are
 * the links it covered and the requests that reached a real ActionStatus (an id a 201 had answered).
 * Exits 1 on any 5xx or failure. Options: --examples N (Schemathesis --max-examples per operation,
 * default 20), --seed N (default 1), --json (the figures as one JSON line).
 */
import { spawnSync } from "node:child_process";
import { existsSync, mkdtempSync, readdirSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { cli, repo, serveBenchTwin } from "./bench-twin.mjs";

const schemathesis = join(repo, "sim-backend/.venv/bin/schemathesis");
const arg = (name, def) => {
  const i = process.argv.indexOf(`--${name}`);
  return i > 0 ? Number(process.argv[i + 1]) : def;
};
const EXAMPLES = arg("examples", 20);
const STATEFUL_EXAMPLES = arg("stateful-examples", 50);
const SEED = arg("seed", 1);
const JSON_OUT = process.argv.includes("--json");
const CHECKS = ["not_a_server_error", "response_schema_conformance", "status_code_conformance", "content_type_conformance"];
/** Schemathesis failure codes by what they mean here. */
const KINDS = {
  ST101: "5xx",
  ST102: "5xx",
  ST103: "undocumented status",
  ST104: "content type",
  ST105: "content type",
  ST106: "content type",
  ST108: "schema violation",
  ST109: "schema violation",
  ST110: "schema violation",
  ST111: "schema violation",
};

if (!existsSync(schemathesis)) {
  console.error(`bench:fuzz: ${schemathesis} not found: npm install creates the backend's venv with its dev tools (schemathesis)`);
  process.exit(1);
}
const work = mkdtempSync(join(tmpdir(), "robwot-bench-fuzz-"));
const served = await serveBenchTwin("fuzz", 2000);
const { twin, info } = served;
let code = 1;
try {
  const doc = join(work, "openapi.json");
  const oa = spawnSync(process.execPath, [cli, "openapi", twin, "--base", info.url, "--out", doc], { stdio: ["ignore", "inherit", "pipe"], encoding: "utf8" });
  if (oa.status !== 0) throw new Error(`robwot openapi failed: ${oa.stderr}`);
  const reports = join(work, "reports");
  const run = (phases, examples, dir) => {
    const args = [
      "run", doc, "--url", info.url, "--checks", CHECKS.join(","), "--exclude-path-regex", "/(observable|sse)$|/events/",
      "--phases", phases, "--max-examples", String(examples), "--seed", String(SEED), "--workers", "1",
      "--request-timeout", "60", "--report", "json,har", "--report-dir", dir,
    ];
    // cwd: Schemathesis keeps a cache folder (.schemathesis) in its working folder
    const st = spawnSync(schemathesis, args, { cwd: work, encoding: "utf8", maxBuffer: 64 << 20 });
    const file = (prefix) => {
      const f = readdirSync(dir).find((n) => n.startsWith(prefix));
      if (!f) throw new Error(`schemathesis wrote no ${prefix} report (exit ${st.status}):\n${st.stdout}\n${st.stderr}`);
      return JSON.parse(readFileSync(join(dir, f), "utf8"));
    };
    return { st, report: file("json-"), har: file("har-") };
  };
  const t0 = performance.now();
  const { report, har } = run("examples,coverage,fuzzing", EXAMPLES, reports);
  const seconds = (performance.now() - t0) / 1000;
  const stateful = run("stateful", STATEFUL_EXAMPLES, join(work, "stateful"));
  // "API Links:    3 covered / 6 selected / 6 total": only the console says it
  const links = /API Links:\s+(\d+) covered \/ (\d+) selected/.exec(stateful.st.stdout);
  // requests on an ActionStatus a 201 had created (its Location): the links at work, by method and answer
  const created = new Set();
  const chained = {};
  for (const e of stateful.har.log.entries) {
    const location = e.response.headers.find((h) => h.name.toLowerCase() === "location")?.value;
    if (e.response.status === 201 && location) created.add(new URL(location).pathname);
    const path = new URL(e.request.url).pathname;
    if (created.has(path)) chained[`${e.request.method} ${e.response.status}`] = (chained[`${e.request.method} ${e.response.status}`] ?? 0) + 1;
  }

  // one row per documented operation; Schemathesis also probes other methods on its paths (405)
  const documented = JSON.parse(readFileSync(doc, "utf8")).paths;
  const rows = new Map();
  for (const e of har.log.entries) {
    const path = new URL(e.request.url).pathname;
    const method = Object.keys(documented[path] ?? {})[0]?.toUpperCase() ?? "?";
    const op = `${method} ${path}`;
    const row = rows.get(op) ?? { requests: 0, "2xx": 0, "4xx": 0, "5xx": 0 };
    row.requests++;
    const cls = `${Math.floor(e.response.status / 100)}xx`;
    if (cls in row) row[cls]++;
    rows.set(op, row);
  }
  const failures = [...report.failures, ...stateful.report.failures];
  const errors = [...report.errors, ...stateful.report.errors];
  const byKind = {};
  for (const f of failures) {
    const kind = KINDS[f.code] ?? f.title;
    byKind[kind] = (byKind[kind] ?? 0) + f.count;
  }
  const total = [...rows.values()].reduce((a, r) => ({ requests: a.requests + r.requests, "5xx": a["5xx"] + r["5xx"] }), { requests: 0, "5xx": 0 });
  const figures = {
    operations: report.operations.tested,
    cases: report.test_cases.generated,
    requests: total.requests,
    responses5xx: total["5xx"] + stateful.har.log.entries.filter((e) => e.response.status >= 500).length,
    schemaViolations: byKind["schema violation"] ?? 0,
    undocumentedStatus: byKind["undocumented status"] ?? 0,
    contentType: byKind["content type"] ?? 0,
    failures: failures.map((f) => ({ code: f.code, title: f.title, count: f.count, operations: f.operations })),
    errors,
    stateful: {
      cases: stateful.report.test_cases.generated,
      linksCovered: links ? Number(links[1]) : 0,
      links: links ? Number(links[2]) : 0,
      created: created.size,
      chained,
    },
    seconds: Math.round(seconds * 10) / 10,
    examples: EXAMPLES,
    seed: SEED,
  };
  if (JSON_OUT) {
    process.stdout.write(`${JSON.stringify(figures)}\n`);
  } else {
    const w = Math.max(...[...rows.keys()].map((k) => k.length), 46);
    const lines = [`Schemathesis ${report.schemathesis_version}, --max-examples ${EXAMPLES}, --seed ${SEED}, checks ${CHECKS.join(", ")}`, ""];
    lines.push(`${"operation (requests: all methods on its path)".padEnd(w)}  requests    2xx    4xx    5xx`);
    for (const [op, r] of [...rows].sort()) {
      lines.push(`${op.padEnd(w)}  ${String(r.requests).padStart(8)} ${String(r["2xx"]).padStart(6)} ${String(r["4xx"]).padStart(6)} ${String(r["5xx"]).padStart(6)}`);
    }
    lines.push("");
    lines.push(`operations ${figures.operations}, test cases ${figures.cases}, requests ${figures.requests}, in ${figures.seconds} s`);
    lines.push(`5xx answers ${figures.responses5xx}, schema violations ${figures.schemaViolations}, undocumented statuses ${figures.undocumentedStatus}, content-type failures ${figures.contentType}`);
    const sf = figures.stateful;
    const chain = Object.entries(sf.chained).map(([k, n]) => `${k} x${n}`).join(", ") || "none";
    lines.push(`stateful (--max-examples ${STATEFUL_EXAMPLES}): ${sf.cases} cases, links ${sf.linksCovered} of ${sf.links} covered, ${sf.created} ActionStatus created, requests on them: ${chain}`);
    for (const f of failures) lines.push(`  ${f.code} ${f.title} x${f.count}: ${f.operations.join(", ")}`);
    for (const e of errors) lines.push(`  error: ${e.title} x${e.count}`);
    process.stdout.write(`${lines.join("\n")}\n`);
  }
  code = figures.responses5xx === 0 && failures.length === 0 && errors.length === 0 && figures.cases > 0 ? 0 : 1;
} finally {
  await served.stop();
  rmSync(work, { recursive: true, force: true });
}
process.exit(code);
