#!/usr/bin/env node
/**
 * `npm test`: every stage runs, whatever an earlier one did (pytest, ruff + mypy, eslint, vitest), and the
 * summary names each stage's outcome and time; the exit code is 1 when any stage failed. A chain of `&&`
 * would stop at the first failure and leave lint and the TypeScript tests unrun.
 *
 * `node scripts/test.mjs [STAGE...]` runs only the named stages (the npm scripts of the table below).
 */
import { spawnSync } from "node:child_process";

const STAGES = ["test:py", "lint:py", "lint:ts", "test:ts"];

const asked = process.argv.slice(2);
const unknown = asked.filter((s) => !STAGES.includes(s));
if (unknown.length > 0) {
  process.stderr.write(`unknown stage(s) ${unknown.join(", ")}; stages: ${STAGES.join(", ")}\n`);
  process.exit(2);
}

const results = [];
for (const stage of asked.length > 0 ? asked : STAGES) {
  process.stdout.write(`\n== npm run ${stage}\n`);
  const start = process.hrtime.bigint();
  const r = spawnSync("npm", ["run", "--silent", stage], { stdio: "inherit" });
  const seconds = Number(process.hrtime.bigint() - start) / 1e9;
  results.push({ stage, ok: r.status === 0, why: r.status === null ? `killed by ${r.signal}` : `exit ${r.status}`, seconds });
}

process.stdout.write("\n== summary\n");
for (const r of results) process.stdout.write(`${r.ok ? "passed" : "FAILED"}  ${r.stage.padEnd(8)} ${r.seconds.toFixed(0).padStart(5)} s${r.ok ? "" : `  (${r.why})`}\n`);
const failed = results.filter((r) => !r.ok);
process.stdout.write(failed.length === 0 ? "every stage passed\n" : `${failed.length} of ${results.length} stage(s) failed: ${failed.map((r) => r.stage).join(", ")}\n`);
process.exit(failed.length === 0 ? 0 : 1);
