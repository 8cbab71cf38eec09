import { spawn } from "node:child_process";
import { chmodSync, mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, describe, expect, it } from "vitest";
import { once } from "node:events";
import { BackendStartError, ConnectionClosedError, connect, launchBackend, type LaunchedBackend, spawnBackend } from "./index.js";

const started: LaunchedBackend[] = [];
afterAll(async () => {
  await Promise.all(started.map((b) => b.stop()));
});

function script(body: string): string {
  const dir = mkdtempSync(join(tmpdir(), "robwot-launcher-"));
  const file = join(dir, "fake-python.sh");
  writeFileSync(file, `#!/bin/sh\n${body}\n`);
  chmodSync(file, 0o755);
  return file;
}

describe("launchBackend", () => {
  it("starts the venv backend on a free port, answers ping, stops with SIGTERM and emits exit", async () => {
    const backend = await launchBackend();
    started.push(backend);
    expect(backend.url).toMatch(/^ws:\/\/127\.0\.0\.1:\d+$/);
    expect(backend.port).toBeGreaterThan(0);
    const ping = await backend.client.ping();
    expect(ping.pybullet).toBe("3.2.7");
    expect(ping.pybulletData).toContain("pybullet_data");
    const exits: unknown[] = [];
    backend.on("exit", (info) => exits.push(info));
    await backend.stop();
    expect(exits).toEqual([{ code: 0, signal: null }]);
    expect(backend.running).toBe(false);
    await backend.stop(); // idempotent
  });

  it("signals the backend at the stop call itself, so a caller busy after it does not hold its exit back", async () => {
    const backend = await launchBackend();
    started.push(backend);
    const stopping = backend.stop();
    expect(backend.process.killed).toBe(true); // no turn of the event loop since the call
    await stopping;
    expect(backend.running).toBe(false);
  });

  it("lets a second client with the backend's token connect to the same backend by URL", async () => {
    const backend = await launchBackend();
    started.push(backend);
    const other = await connect(backend.url, { token: backend.token });
    await backend.client.loadRobot({ urdf: "kuka_iiwa/model.urdf", id: "shared" });
    const world = await other.listWorld();
    expect(world.robots.map((r) => r.id)).toEqual(["shared"]);
    await other.close();
    await backend.stop();
  });

  it("reports an unexpected exit (for restarts) and fails pending calls with ConnectionClosedError", async () => {
    const backend = await launchBackend();
    started.push(backend);
    await backend.client.loadRobot({ urdf: "kuka_iiwa/model.urdf", id: "k" });
    const move = backend.client.move({ robot: "k", target: [2, 0, 0, 0, 0, 0, 0], speed: 0.05 }).catch((e: unknown) => e);
    const exited = new Promise((resolve) => backend.once("exit", resolve));
    backend.process.kill("SIGKILL");
    expect(await exited).toEqual({ code: null, signal: "SIGKILL" });
    expect(await move).toBeInstanceOf(ConnectionClosedError);
  });

  it("takes the backend down when the launching process is SIGKILLed", async () => {
    const entry = new URL("../dist/index.js", import.meta.url).href;
    const code = `const { launchBackend } = await import(${JSON.stringify(entry)});
      const b = await launchBackend(); console.log(b.pid); setInterval(() => {}, 1000);`;
    const parent = spawn(process.execPath, ["--input-type=module", "-e", code], { stdio: ["ignore", "pipe", "inherit"] });
    const pid = await new Promise<number>((resolve, reject) => {
      parent.stdout.once("data", (d: Buffer) => resolve(Number(d.toString().trim())));
      parent.once("exit", (c) => reject(new Error(`launcher exited early (${c})`)));
    });
    const alive = (): boolean => {
      try {
        process.kill(pid, 0);
        return true;
      } catch {
        return false;
      }
    };
    expect(alive()).toBe(true);
    parent.kill("SIGKILL");
    const deadline = Date.now() + 15_000;
    while (alive() && Date.now() < deadline) await new Promise((r) => setTimeout(r, 100));
    expect(alive()).toBe(false);
  });

  it("fails clearly when the interpreter is missing", async () => {
    const err = await launchBackend({ python: "/nonexistent/python" }).catch((e: unknown) => e);
    expect(err).toBeInstanceOf(BackendStartError);
    expect((err as BackendStartError).message).toContain("/nonexistent/python");
    expect((err as BackendStartError).code).toBe("E_BACKEND_START");
  });

  it("honours ROBWOT_PYTHON and includes the stderr tail when the backend dies before ready", async () => {
    const fake = script('echo "ModuleNotFoundError: No module named robwot_sim" >&2; exit 3');
    const saved = process.env.ROBWOT_PYTHON;
    process.env.ROBWOT_PYTHON = fake;
    try {
      const err = (await launchBackend().catch((e: unknown) => e)) as BackendStartError;
      expect(err).toBeInstanceOf(BackendStartError);
      expect(err.exitCode).toBe(3);
      expect(err.stderrTail).toContain("No module named robwot_sim");
      expect(err.message).toContain("exited with code 3");
    } finally {
      if (saved === undefined) delete process.env.ROBWOT_PYTHON;
      else process.env.ROBWOT_PYTHON = saved;
    }
  });

  it("connects to a backend started before (spawnBackend) whose ready line was written before it was adopted", async () => {
    const spawned = spawnBackend();
    const deadline = Date.now() + 30_000;
    while (!spawned.stdout.includes('"ready"') && Date.now() < deadline) await new Promise((r) => setTimeout(r, 20));
    expect(spawned.stdout).toContain('"ready"');
    const backend = await launchBackend({ spawned, startTimeoutMs: 2000 });
    started.push(backend);
    expect(backend.pid).toBe(spawned.child.pid);
    expect((await backend.client.ping()).pybulletData).toContain("pybullet_data");
    await backend.stop();
    expect(backend.running).toBe(false);
  });

  it("reports a started backend that ended before it was adopted, with its exit code and stderr", async () => {
    const spawned = spawnBackend({ python: script('echo "cannot import numpy" >&2; exit 3') });
    await once(spawned.child, "exit");
    const err = (await launchBackend({ spawned }).catch((e: unknown) => e)) as BackendStartError;
    expect(err).toBeInstanceOf(BackendStartError);
    expect(err.exitCode).toBe(3);
    expect(err.stderrTail).toContain("cannot import numpy");
  });

  it("reports an interpreter that cannot be started, found only once the start was tried", async () => {
    const spawned = spawnBackend({ python: "robwot-no-such-python" });
    await once(spawned.child, "error"); // the spawn's error event has come and gone before the launch
    expect(spawned.error?.message).toContain("ENOENT");
    const err = (await launchBackend({ spawned }).catch((e: unknown) => e)) as BackendStartError;
    expect(err).toBeInstanceOf(BackendStartError);
    expect(err.message).toContain("cannot start the backend");
  });

  it("times out waiting for the ready line with the stderr tail in the error", async () => {
    const fake = script('echo "still importing" >&2; exec sleep 30');
    const err = (await launchBackend({ python: fake, startTimeoutMs: 500 }).catch((e: unknown) => e)) as BackendStartError;
    expect(err).toBeInstanceOf(BackendStartError);
    expect(err.message).toContain("not ready within 500 ms");
    expect(err.stderrTail).toContain("still importing");
  });
});
