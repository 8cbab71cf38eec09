/**
 * End to end: `robwot generate --cluster ADDRESS` (real CLI, real backend, a real local Ray cluster started
 * with `ray start --head --block`, 2 CPUs) writes the same workspace files as a local run, and the twin it
 * writes is served like any other. Opt-in like the Python Ray tests: ROBWOT_RAY_TESTS=1 (set by .ci/run,
 * which installs the backend's `cluster` extra).
 */
import { type ChildProcess, spawn } from "node:child_process";
import { mkdtempSync, readFileSync, rmSync } from "node:fs";
import { createConnection } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { REPO, runCli } from "./cli-run.js";
import { freePort, waitFor } from "./serve-helpers.js";

const ENABLED = process.env.ROBWOT_RAY_TESTS === "1";
const FILES = ["workspace.csv", "workspace.stl", "reachability.csv"];

function listening(port: number): Promise<boolean> {
  return new Promise((resolve) => {
    const c = createConnection({ host: "127.0.0.1", port }, () => {
      c.end();
      resolve(true);
    });
    c.on("error", () => resolve(false));
  });
}

describe.skipIf(!ENABLED)("robwot generate --cluster (local Ray cluster)", () => {
  let work: string;
  let head: ChildProcess | undefined;
  let address: string;

  beforeAll(async () => {
    work = mkdtempSync(join(tmpdir(), "robwot-cluster-"));
    const port = await freePort();
    address = `127.0.0.1:${port}`;
    head = spawn(join(REPO, "sim-backend", ".venv", "bin", "ray"),
      ["start", "--head", "--block", `--port=${port}`, "--num-cpus=2", "--include-dashboard=false",
        "--disable-usage-stats", `--temp-dir=${join(work, "ray")}`],
      { stdio: "ignore", env: { ...process.env, RAY_USAGE_STATS_ENABLED: "0" } });
    await waitFor(async () => head?.exitCode !== null || (await listening(port)), { timeoutMs: 120_000, intervalMs: 500, what: "ray's head listening" });
    if (head.exitCode !== null) throw new Error("ray start --head failed");
  }, 150_000);

  afterAll(async () => {
    if (head && head.exitCode === null) {
      const exited = new Promise((r) => head?.once("exit", r));
      head.kill("SIGTERM");
      await Promise.race([exited, new Promise((r) => setTimeout(r, 60_000))]);
      if (head.exitCode === null) head.kill("SIGKILL");
    }
    rmSync(work, { recursive: true, force: true });
  }, 90_000);

  it("writes the same workspace files, summary and TD title as a local run", async () => {
    const args = ["generate", "kuka_iiwa", "--samples", "2500", "--seed", "9", "--csv-joints", "--json"];
    const local = await runCli([...args, "--out", join(work, "local")], { timeoutMs: 180_000 });
    expect(local.code, local.stderr).toBe(0);
    const ray = await runCli([...args, "--out", join(work, "on-ray"), "--cluster", address], { timeoutMs: 180_000 });
    expect(ray.code, ray.stderr).toBe(0);
    for (const f of FILES) expect(readFileSync(join(work, "on-ray", f)).equals(readFileSync(join(work, "local", f))), f).toBe(true);
    const a = JSON.parse(local.stdout) as { summary: Record<string, unknown> };
    const b = JSON.parse(ray.stdout) as { summary: Record<string, unknown> };
    for (const key of ["samples", "collisionFree", "bounds", "alpha", "volume", "reachability"]) expect(b.summary[key]).toEqual(a.summary[key]);
    const td = JSON.parse(readFileSync(join(work, "on-ray", "td.json"), "utf8")) as { title: string };
    expect(td.title).toBe(JSON.parse(readFileSync(join(work, "local", "td.json"), "utf8")).title);
  }, 400_000);
});
