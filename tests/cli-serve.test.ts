/**
 * End to end: `robwot serve` as a real child process on port 0 serves a generated twin (TD, files,
 * property read) and stops its backend on SIGINT; bad folders are refused before anything starts.
 */
import { spawn } from "node:child_process";
import { once } from "node:events";
import { createServer, type AddressInfo } from "node:net";
import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { CLI, REPO, runCli, TINY_URDF } from "./cli-run.js";

let work: string;
let twin: string;

beforeAll(async () => {
  work = mkdtempSync(join(tmpdir(), "robwot-cli-serve-"));
  writeFileSync(join(work, "tiny.urdf"), TINY_URDF);
  twin = join(work, "tiny-twin");
  const r = await runCli(["generate", join(work, "tiny.urdf"), "--samples", "1000", "--out", twin]);
  expect(r.code, r.stderr).toBe(0);
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

describe("robwot serve", () => {
  it("serves the twin on port 0, prints its URLs, and stops cleanly on SIGINT", async () => {
    const child = spawn(process.execPath, [CLI, "serve", twin, "--port", "0", "--json"], { cwd: REPO, stdio: ["ignore", "pipe", "pipe"] });
    let stdout = "";
    let stderr = "";
    child.stderr.on("data", (d: Buffer) => (stderr += d.toString()));
    const exited = new Promise<number | null>((resolve) => child.on("close", (code) => resolve(code)));
    const info = await new Promise<{ url: string; liveUrl: string; things: { slug: string; tdUrl: string; viewerUrl: string }[] }>(
      (resolve, reject) => {
        child.stdout.on("data", (d: Buffer) => {
          stdout += d.toString();
          const nl = stdout.indexOf("\n");
          if (nl >= 0) resolve(JSON.parse(stdout.slice(0, nl)));
        });
        void exited.then((code) => reject(new Error(`serve exited (${code}) before printing its URLs:\n${stderr}`)));
      },
    );
    try {
      expect(info.url).toMatch(/^http:\/\/127\.0\.0\.1:\d+$/);
      expect(info.things).toHaveLength(1);
      const thing = info.things[0]!;
      const td = (await (await fetch(thing.tdUrl)).json()) as { title: string; properties: Record<string, unknown> };
      expect(td.title).toBe("tiny_arm");
      expect(Object.keys(td.properties)).toContain("getJointPosition");
      const joints = (await (await fetch(`${info.url}/${thing.slug}/properties/getJointPosition`)).json()) as Record<string, number>;
      expect(Object.keys(joints).sort()).toEqual(["elbow", "shoulder", "yaw"]);
      const stl = await fetch(`${info.url}/${thing.slug}/workspace.stl`);
      expect(stl.status).toBe(200);
      expect(stderr).not.toMatch(/unknown format|Warning:/);
    } finally {
      child.kill("SIGINT");
    }
    expect(await exited).toBe(130);
    expect(stderr).toMatch(/robwot: interrupted, cleaning up/);
    expect(stderr).not.toMatch(/robwot: error/);
  });

  it.each([
    ["a missing folder", () => [join(work, "nope")], /twin folder not found: .*nope/],
    ["a folder that is not a twin", () => [join(work, "empty")], /is not a twin folder: no td\.json/],
    ["a bad --auth", () => [twin, "--auth", "digest:x"], /--auth must be basic:USER:PASS or bearer:TOKEN/],
  ])("refuses %s before starting anything", async (_name, args, message) => {
    mkdirSync(join(work, "empty"), { recursive: true });
    const r = await runCli(["serve", ...args(), "--port", "0"]);
    expect(r.code).not.toBe(0);
    expect(r.stderr).toMatch(message);
    expect(r.stdout).toBe("");
  });

  it("refuses a port another server holds, naming it", async () => {
    const holder = createServer().listen(0, "127.0.0.1");
    await once(holder, "listening");
    const port = (holder.address() as AddressInfo).port;
    try {
      const r = await runCli(["serve", twin, "--port", String(port)]);
      expect(r.code).not.toBe(0);
      expect(r.stderr).toMatch(new RegExp(`port ${port} on 127\\.0\\.0\\.1 is in use \\(choose another with --port`));
    } finally {
      holder.close();
    }
  });
});
