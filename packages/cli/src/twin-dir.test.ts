import { existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync, statSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterEach, beforeEach, describe, expect, it } from "vitest";
import { StagedDir } from "./twin-dir.js";

let parent: string;
beforeEach(() => {
  parent = mkdtempSync(join(tmpdir(), "robwot-staged-"));
});
afterEach(() => rmSync(parent, { recursive: true, force: true }));

describe("StagedDir", () => {
  it("stages next to the output and moves it into place on commit", () => {
    const out = join(parent, "twin");
    const s = StagedDir.create(out);
    expect(readdirSync(parent)).toEqual([expect.stringMatching(/^\.twin\.tmp-/)]);
    writeFileSync(join(s.tmp, "twin.json"), "new");
    s.commit();
    expect(readFileSync(join(out, "twin.json"), "utf8")).toBe("new");
    expect(readdirSync(parent)).toEqual(["twin"]);
    expect(statSync(out).mode & 0o777).toBe(0o755);
  });

  it("replaces an existing twin only on commit, and leaves it intact on discard", () => {
    const out = join(parent, "twin");
    mkdirSync(out);
    writeFileSync(join(out, "twin.json"), "old");
    const failed = StagedDir.create(out);
    writeFileSync(join(failed.tmp, "twin.json"), "half");
    failed.discard();
    expect(readFileSync(join(out, "twin.json"), "utf8")).toBe("old");
    expect(readdirSync(parent)).toEqual(["twin"]);
    const ok = StagedDir.create(out);
    writeFileSync(join(ok.tmp, "twin.json"), "new");
    ok.commit();
    ok.discard();
    expect(readFileSync(join(out, "twin.json"), "utf8")).toBe("new");
    expect(readdirSync(parent)).toEqual(["twin"]);
  });

  it("refuses a non-empty folder that is not a twin unless forced, and a file", () => {
    const out = join(parent, "docs");
    mkdirSync(out);
    writeFileSync(join(out, "thesis.tex"), "x");
    expect(() => StagedDir.create(out)).toThrow(/not a twin folder/);
    StagedDir.create(out, { force: true }).discard();
    writeFileSync(join(parent, "file"), "x");
    expect(() => StagedDir.create(join(parent, "file"))).toThrow(/not a directory/);
    expect(() => StagedDir.create(join(parent, "file", "sub"))).toThrow(/cannot create output folder/);
    expect(existsSync(join(out, "thesis.tex"))).toBe(true);
  });

  it("removes the parent folders it created when the run fails, and keeps ones that were there", () => {
    const staged = StagedDir.create(join(parent, "twins", "nested", "kuka"));
    expect(existsSync(join(parent, "twins", "nested"))).toBe(true);
    staged.discard();
    expect(readdirSync(parent)).toEqual([]);
    mkdirSync(join(parent, "mine"));
    StagedDir.create(join(parent, "mine", "kuka")).discard();
    expect(readdirSync(parent)).toEqual(["mine"]);
  });
});
