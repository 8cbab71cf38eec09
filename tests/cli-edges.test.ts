/**
 * `robwot generate` never destroys what is not a twin and never leaves debris: absurd outputs (the file
 * system root, the home folder, the working folder, a folder holding the input) are refused before any
 * work even with --force, and a run interrupted by SIGHUP, SIGTERM or SIGINT removes its temporary
 * folder. Real CLI processes, real backend.
 */
import { execFileSync, spawn } from "node:child_process";
import { cpSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync, symlinkSync, writeFileSync } from "node:fs";
import { homedir, tmpdir } from "node:os";
import { basename, join } from "node:path";
import { beforeAll, describe, expect, it } from "vitest";
import { CLI, REPO, runCli, TINY_URDF } from "./cli-run.js";
import { invoke, waitFor } from "./serve-helpers.js";

describe("absurd outputs are refused before any work", () => {
  const urdfIn = (): { dir: string; urdf: string } => {
    const dir = mkdtempSync(join(tmpdir(), "robwot-in-"));
    const urdf = join(dir, "arm.urdf");
    writeFileSync(urdf, TINY_URDF);
    return { dir, urdf };
  };

  it.each([
    ["the file system root", () => "/", /file system root/],
    ["the home folder", () => homedir(), /home folder/],
    ["the working folder", () => REPO, /working folder/],
  ])("--out %s --force: exit 2 at once", async (_what, out, message) => {
    const { urdf } = urdfIn();
    const r = await runCli(["generate", urdf, "--out", out(), "--force", "--samples", "500"], { timeoutMs: 20_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(message);
    expect(r.stderr).not.toMatch(/backend|labelling|sampling/i);
  });

  it("--force on the folder holding the input URDF is refused and the URDF survives", async () => {
    const { dir, urdf } = urdfIn();
    mkdirSync(join(dir, "meshes"));
    const r = await runCli(["generate", urdf, "--out", dir, "--force", "--samples", "500"], { timeoutMs: 20_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toContain(`holds the input ${urdf}`);
    expect(existsSync(urdf)).toBe(true);
    expect(readdirSync(dir).sort()).toEqual(["arm.urdf", "meshes"]);
  });

  it("--force on the folder holding the input, reached through a symbolic link, is refused and the URDF survives", async () => {
    const { dir, urdf } = urdfIn();
    const links = mkdtempSync(join(tmpdir(), "robwot-links-"));
    symlinkSync(join(dir, ".."), join(links, "up"));
    const out = join(links, "up", basename(dir));
    const r = await runCli(["generate", urdf, "--out", out, "--force", "--samples", "500"], { timeoutMs: 60_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toContain(`holds the input ${urdf}`);
    expect(readdirSync(dir)).toEqual(["arm.urdf"]);
  });

  it("--force on the root of a repository is refused, the repository untouched", async () => {
    const { urdf } = urdfIn();
    const repo = mkdtempSync(join(tmpdir(), "robwot-repo-"));
    mkdirSync(join(repo, ".git"));
    writeFileSync(join(repo, "main.c"), "int main(void) { return 0; }\n");
    const r = await runCli(["generate", urdf, "--out", repo, "--force", "--samples", "500"], { timeoutMs: 60_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/root of a repository/);
    expect(readdirSync(repo).sort()).toEqual([".git", "main.c"]);
  });

  it("an existing folder that is not a twin, without --force: exit 2 at once, untouched", async () => {
    const { urdf } = urdfIn();
    const docs = mkdtempSync(join(tmpdir(), "robwot-docs-"));
    writeFileSync(join(docs, "thesis.tex"), "precious");
    const r = await runCli(["generate", urdf, "--out", docs, "--samples", "500"], { timeoutMs: 60_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/is not a twin folder/);
    expect(r.stderr).not.toMatch(/backend|labelling|sampling/i);
    expect(readFileSync(join(docs, "thesis.tex"), "utf8")).toBe("precious");
  });
});

describe("an interrupted generate leaves nothing behind", () => {
  it.each([
    ["SIGHUP", 129],
    ["SIGTERM", 143],
    ["SIGINT", 130],
  ] as const)("%s during the run: exit %i, no temporary folder, no output", async (signal, code) => {
    const parent = mkdtempSync(join(tmpdir(), "robwot-sig-"));
    const child = spawn(process.execPath, [CLI, "generate", "kuka_iiwa", "--samples", "400000", "--out", join(parent, "twin")], {
      cwd: REPO,
      stdio: ["ignore", "pipe", "pipe"],
    });
    let stderr = "";
    child.stderr.on("data", (d: Buffer) => (stderr += d.toString()));
    const exited = new Promise<number | null>((r) => child.on("close", (c) => r(c)));
    // signal once the run is under way: the staged folder exists and the backend, up, loads the robot
    await waitFor(() => readdirSync(parent).some((f) => f.includes(".tmp-")) && /robwot: (load|sample|collide)/.test(stderr), {
      timeoutMs: 60_000,
      what: "a staged folder and a work stage",
    });
    child.kill(signal);
    expect(await exited).toBe(code);
    expect(readdirSync(parent)).toEqual([]);
    expect(stderr).toMatch(/cleaning up/);
  });
});

describe("twins that could not be served are not written, and folders missing workspace files are not served", () => {
  it("a robot whose end effector reaches one point only: generate exits 1 with the reason, nothing written", async () => {
    const dir = mkdtempSync(join(tmpdir(), "robwot-point-"));
    const urdf = join(dir, "spinner.urdf");
    writeFileSync(
      urdf,
      `<robot name="spinner"><link name="base"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>
<link name="tip"><collision><geometry><sphere radius="0.01"/></geometry></collision></link>
<joint name="spin" type="revolute"><parent link="base"/><child link="tip"/><origin xyz="0 0 0.3"/>
<axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>`,
    );
    const r = await runCli(["generate", urdf, "--samples", "500", "--out", join(dir, "twin")], { timeoutMs: 120_000 });
    expect(r.code).toBe(1);
    expect(r.stderr).toMatch(/degenerate.*single point only/);
    expect(readdirSync(dir)).toEqual(["spinner.urdf"]);
  });

  let planar: string;
  beforeAll(async () => {
    planar = join(mkdtempSync(join(tmpdir(), "robwot-planar-")), "twin");
    const r = await runCli(["generate", "two_joint", "--samples", "2000", "--out", planar], { timeoutMs: 120_000 });
    expect(r.code, r.stderr).toBe(0);
  });

  const allColliding = (csv: string): string => csv.replace(/,1$/gm, ",0");
  it.each([
    ["without workspace.stl", (d: string) => rmSync(join(d, "workspace.stl")), "has no workspace.stl"],
    ["without workspace.json", (d: string) => rmSync(join(d, "workspace.json")), "has no workspace.json"],
    ["whose workspace.csv has no collision-free point", (d: string) => writeFileSync(join(d, "workspace.csv"), allColliding(readFileSync(join(d, "workspace.csv"), "utf8"))), "workspace.csv has no collision-free point"],
    ["whose workspace.json bounds are 1e400", (d: string) => writeFileSync(join(d, "workspace.json"), readFileSync(join(d, "workspace.json"), "utf8").replace(/"max": \[\s*[-\d.e]+/, '"max": [1e400')), "workspace.json: bounds must be"],
  ])("serve refuses a twin folder %s, naming the file (exit 1)", async (_what, spoil, message) => {
    const out = join(mkdtempSync(join(tmpdir(), "robwot-spoilt-")), "twin");
    cpSync(planar, out, { recursive: true });
    spoil(out);
    const r = await runCli(["serve", out, "--port", "0"], { timeoutMs: 60_000 });
    expect(r.code).toBe(1);
    expect(r.stderr).toContain(message);
  });

  it("the planar two_joint twin (a 2 mm slab around its plane) is served and accepts its reachable targets", async () => {
    const child = spawn(process.execPath, [CLI, "serve", planar, "--port", "0"], { cwd: REPO, stdio: ["ignore", "pipe", "pipe"] });
    let stdout = "";
    child.stdout.on("data", (d: Buffer) => (stdout += d.toString()));
    const exited = new Promise<number | null>((r) => child.on("close", (c) => r(c)));
    await waitFor(() => stdout.includes("serving 1 twin") || child.exitCode !== null, { timeoutMs: 60_000, what: "serve's banner" });
    expect(stdout).toContain("serving 1 twin");
    expect(JSON.parse(readFileSync(join(planar, "workspace.json"), "utf8"))).toMatchObject({ method: "planar-alpha-shape", halfThickness: 0.001 });
    const base = /TD\s+(http:\S+)/.exec(stdout)?.[1] ?? "";
    const free = readFileSync(join(planar, "workspace.csv"), "utf8").trim().split("\n").slice(1)
      .map((l) => l.split(",").map(Number)).filter((r) => r[3] === 1);
    let inside = 0;
    for (const [x, y, z] of free.filter((_, i) => i % Math.floor(free.length / 20) === 0).slice(0, 20)) {
      const r = await invoke(base, "validateCartesianPosition", { x, y, z });
      expect(r.status, JSON.stringify(r.body)).toBe(200);
      if (r.body.checks.insideWorkspace.ok) inside++;
      expect(r.body.valid, JSON.stringify(r.body)).toBe(true);
    }
    expect(inside).toBeGreaterThanOrEqual(19); // samples on the region's outline may fall just outside
    child.kill("SIGINT");
    await exited;
  });

  it("serve --realtime 0.001 (the backend refuses factors below 0.01) is a usage error, not a 400 on every move", async () => {
    const r = await runCli(["serve", planar, "--port", "0", "--realtime", "0.001"], { timeoutMs: 60_000 });
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(/--realtime must be 0 \(as fast as possible\) or between 0\.01 and 1000, got 0\.001/);
  });
});

describe("a generate whose backend stops answering", () => {
  it("fails with a clear error at the deadline and leaves nothing behind (SIGSTOPped backend)", async () => {
    const parent = mkdtempSync(join(tmpdir(), "robwot-hung-"));
    const child = spawn(process.execPath, [CLI, "generate", "kuka_iiwa", "--samples", "2000000", "--out", join(parent, "twin")], {
      cwd: REPO,
      env: { ...process.env, ROBWOT_BACKEND_DEADLINE_MS: "3000" },
      stdio: ["ignore", "pipe", "pipe"],
    });
    let stderr = "";
    child.stderr.on("data", (d: Buffer) => (stderr += d.toString()));
    const exited = new Promise<number | null>((r) => child.on("close", (c) => r(c)));
    await waitFor(() => /collide|sample/.test(stderr), { timeoutMs: 60_000, what: "a work stage" });
    const backendPid = Number(execFileSync("ps", ["--ppid", String(child.pid), "-o", "pid=", "-o", "comm="], { encoding: "utf8" })
      .split("\n").find((l) => /python/.test(l))?.trim().split(/\s+/)[0]);
    expect(backendPid).toBeGreaterThan(0);
    process.kill(backendPid, "SIGSTOP");
    // the deadline (3 s here) ends the run: the outcome and its reason say so, not a stopwatch
    const code = await exited;
    expect(code).toBe(1);
    expect(stderr).toMatch(/stopped answering/);
    expect(readdirSync(parent)).toEqual([]);
    expect(() => process.kill(backendPid, 0)).toThrow(); // the hung backend was killed, not left stopped
  });
});

describe("the CLI's own help and its README agree", () => {
  it("every command robwot --help lists is in the CLI README's synopsis, and nothing else", async () => {
    const help = await runCli(["--help"]);
    const commands = (text: string): string[] => [...text.matchAll(/^ {0,2}robwot ([a-z]+) /gm)].map((m) => m[1]!).sort();
    const synopsis = /```\n([\s\S]*?)```/.exec(readFileSync(join(REPO, "packages/cli/README.md"), "utf8"))?.[1] ?? "";
    expect(commands(synopsis)).toEqual(commands(help.stdout));
    expect(commands(help.stdout)).toContain("emulate");
  });
});
