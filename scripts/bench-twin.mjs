/**
 * Shared by the benches: a KUKA twin (`robwot generate kuka_iiwa --samples N` into a temp folder, or
 * ROBWOT_BENCH_TWIN=<folder>) served by `robwot serve --port 0 --realtime 0 --json` in its own process.
 */
import { spawn, spawnSync } from "node:child_process";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

export const repo = join(dirname(fileURLToPath(import.meta.url)), "..");
export const cli = join(repo, "packages/cli/dist/main.js");

/** Generates (unless ROBWOT_BENCH_TWIN is set) and serves the twin; `info` is serve's --json line. */
export async function serveBenchTwin(name, samples) {
  let tmp = null;
  let twin = process.env.ROBWOT_BENCH_TWIN;
  if (!twin) {
    tmp = mkdtempSync(join(tmpdir(), `robwot-bench-${name}-`));
    twin = join(tmp, "kuka");
    const r = spawnSync(process.execPath, [cli, "generate", "kuka_iiwa", "--samples", String(samples), "--out", twin], { stdio: ["ignore", "ignore", "inherit"] });
    if (r.status !== 0) process.exit(r.status ?? 1);
  }
  const server = spawn(process.execPath, [cli, "serve", twin, "--port", "0", "--realtime", "0", "--json"], { stdio: ["ignore", "pipe", "pipe"] });
  let serverErr = "";
  server.stderr.on("data", (d) => (serverErr += d.toString()));
  const info = await new Promise((resolve, reject) => {
    let out = "";
    server.stdout.on("data", (d) => {
      out += d.toString();
      const nl = out.indexOf("\n");
      if (nl >= 0) resolve(JSON.parse(out.slice(0, nl)));
    });
    server.once("exit", (code) => reject(new Error(`robwot serve exited with ${code}: ${serverErr}`)));
  });
  return {
    twin,
    info,
    async stop() {
      if (server.exitCode === null) {
        server.kill("SIGINT");
        await new Promise((r) => server.once("exit", r));
      }
      if (tmp) rmSync(tmp, { recursive: true, force: true });
    },
  };
}

/** A CLI command (`serve`, `emulate`) that prints one JSON line once it serves; resolves with it and the process. */
export function startCli(args) {
  const child = spawn(process.execPath, [cli, ...args, "--json"], { stdio: ["ignore", "pipe", "pipe"] });
  let err = "";
  child.stderr.on("data", (d) => (err += d.toString()));
  return new Promise((resolve, reject) => {
    let out = "";
    child.stdout.on("data", (d) => {
      out += d.toString();
      const nl = out.indexOf("\n");
      if (nl >= 0) resolve({ child, info: JSON.parse(out.slice(0, nl)) });
    });
    child.once("exit", (code) => reject(new Error(`robwot ${args[0]} exited with ${code}: ${err}`)));
  });
}

/** Stops a process `startCli` started (SIGINT, as Ctrl-C) and waits for it. */
export async function stopCli(child) {
  if (child.exitCode !== null) return;
  child.kill("SIGINT");
  await new Promise((r) => child.once("exit", r));
}
