import { mkdirSync, mkdtempSync, symlinkSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { beforeAll, describe, expect, it } from "vitest";
import { RobwotError } from "./errors.js";
import { jailFile, realFolder } from "./folder-jail.js";
import { jsonErrorAt, snippet } from "./snippet.js";
import { parseWorkspaceCsv } from "./workspace/csv.js";
import { loadWorkspace } from "./workspace/load-fs.js";

let top: string;
let dir: string;

beforeAll(() => {
  top = realFolder(mkdtempSync(join(tmpdir(), "robwot-jail-")));
  dir = join(top, "twin");
  mkdirSync(join(dir, "meshes"), { recursive: true });
  writeFileSync(join(dir, "robot.urdf"), "<robot/>");
  writeFileSync(join(dir, "meshes", "a.stl"), "x");
  writeFileSync(join(top, "secret.txt"), "root:x:0:0:root:/root:/bin/bash\n");
  symlinkSync(join(top, "secret.txt"), join(dir, "out.urdf"));
  symlinkSync(join(dir, "meshes", "a.stl"), join(dir, "in.stl"));
  symlinkSync(join(top, "nowhere"), join(dir, "dangling.urdf"));
});

describe("jailFile", () => {
  it.each([
    ["a file of the folder", "robot.urdf", { ok: true }],
    ["a file in a sub-folder", "meshes/a.stl", { ok: true }],
    ["a symlink to a file inside", "in.stl", { ok: true }],
    ["an absolute path inside", () => join(dir, "robot.urdf"), { ok: true }],
    ["a path climbing out", "../secret.txt", { ok: false, why: "outside" }],
    ["a path climbing out and back in", "../twin/robot.urdf", { ok: true }],
    ["an absolute path outside", "/etc/passwd", { ok: false, why: "outside" }],
    ["a symlink out", "out.urdf", { ok: false, why: "outside" }],
    ["a dangling symlink", "dangling.urdf", { ok: false, why: "missing" }],
    ["a missing file", "nothing.urdf", { ok: false, why: "missing" }],
    ["a folder", "meshes", { ok: false, why: "not-a-file" }],
    ["a NUL byte", "robot.urdf\0x", { ok: false, why: "not-a-path" }],
    ["not a string", 42, { ok: false, why: "not-a-path" }],
  ])("%s", (_what, entry, expected) => {
    const v = jailFile([realFolder(dir)], realFolder(dir), typeof entry === "function" ? entry() : entry);
    expect(v).toMatchObject(expected);
  });

  it("takes other roots for absolute paths", () => {
    expect(jailFile([dir, top], dir, join(top, "secret.txt"))).toMatchObject({ ok: true });
  });
});

describe("loadWorkspace", () => {
  it("refuses a workspace.csv symlinked out of the folder without reading it", async () => {
    const ws = join(top, "ws");
    mkdirSync(ws);
    writeFileSync(join(ws, "workspace.stl"), "solid x\nendsolid x\n");
    symlinkSync(join(top, "secret.txt"), join(ws, "workspace.csv"));
    const err = await loadWorkspace(ws).catch((e: unknown) => e);
    expect(err).toBeInstanceOf(RobwotError);
    expect((err as Error).message).toMatch(/workspace\.csv: resolves outside its folder/);
    expect((err as Error).message).not.toContain("root:");
  });

  it("quotes at most a short printable snippet of a bad header", () => {
    let err: unknown;
    try {
      parseWorkspaceCsv(`\u001b[2J${"A".repeat(5000)},y,z,collision_free\n`, { file: "w.csv" });
    } catch (e) {
      err = e;
    }
    expect((err as Error).message).toMatch(/header column 1 is '\?\[2JA+\.\.\.'/);
    expect((err as Error).message.length).toBeLessThan(200);
  });
});

describe("snippet and jsonErrorAt", () => {
  it.each([
    ["plain", "abc", "abc"],
    ["control characters and quotes", "a\u0000b\u001bc'd\u00e9", "a?b?c?d?"],
    ["long text", "x".repeat(40), `${"x".repeat(32)}...`],
  ])("snippet of %s", (_what, text, expected) => {
    expect(snippet(text)).toBe(expected);
  });

  it("gives the position of a JSON error, never the text", () => {
    const text = '{\n  "a": 1,\n  oops\n}';
    let err: unknown;
    try {
      JSON.parse(text);
    } catch (e) {
      err = e;
    }
    expect(jsonErrorAt(err, text)).toMatch(/^ at line 3, column \d+$/);
    expect(jsonErrorAt(new Error("Unexpected token 'r', \"root:x:0:0\"... is not valid JSON"), "root:x")).toBe("");
  });
});
