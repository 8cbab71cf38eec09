import { mkdirSync, mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { isLoopback, parseAuth, parseServeArgs } from "./serve-options.js";

let dir: string;
beforeAll(() => {
  dir = mkdtempSync(join(tmpdir(), "robwot-serve-opts-"));
  mkdirSync(join(dir, "twin"));
  writeFileSync(join(dir, "twin", "td.json"), "{}");
  writeFileSync(join(dir, "twin", "twin.json"), "{}");
  mkdirSync(join(dir, "empty"));
});
afterAll(() => rmSync(dir, { recursive: true, force: true }));

describe("serve options", () => {
  it.each([
    ["basic:ada:s3cr:et", { scheme: "basic", user: "ada", password: "s3cr:et" }],
    ["bearer:tok", { scheme: "bearer", token: "tok" }],
  ])("parses --auth %s", (arg, want) => expect(parseAuth(arg)).toEqual(want));

  it.each(["basic:ada", "bearer:", "digest:a:b", "basic::pw"])("refuses --auth %s", (arg) => {
    expect(() => parseAuth(arg)).toThrow(/--auth must be basic:USER:PASS or bearer:TOKEN/);
  });

  it.each([
    ["127.0.0.1", true],
    ["127.1.2.3", true],
    ["localhost", true],
    ["::1", true],
    ["0.0.0.0", false],
    ["192.0.2.7", false],
    ["::", false],
  ])("isLoopback(%s) = %s", (host, want) => expect(isLoopback(host)).toBe(want));

  it("defaults and validation", () => {
    const o = parseServeArgs([join(dir, "twin")]);
    expect(o).toMatchObject({ port: 8080, host: "127.0.0.1", realtime: 1, json: false });
    expect(() => parseServeArgs([join(dir, "empty")])).toThrow(/is not a twin folder: no td\.json/);
    expect(() => parseServeArgs([join(dir, "nope")])).toThrow(/twin folder not found/);
    expect(() => parseServeArgs([join(dir, "twin"), "--port", "70000"])).toThrow(/--port must be between 0 and 65535/);
    expect(() => parseServeArgs([join(dir, "twin"), "--relay", "ftp://x"])).toThrow(/--relay must use http or https/);
    expect(() => parseServeArgs([])).toThrow(/missing twin folder/);
  });

  it("--relay with one twin folder mirrors that Thing too, unless --no-follow", () => {
    const twin = join(dir, "twin");
    const url = "http://127.0.0.1:8081/robot-emulated";
    expect(parseServeArgs([twin, "--relay", url])).toMatchObject({ relay: url, follow: url, followRate: 50, monitor: "stop" });
    expect(parseServeArgs([twin, "--relay", url, "--follow-rate", "20"]).followRate).toBe(20);
    const off = parseServeArgs([twin, "--relay", url, "--no-follow"]);
    expect(off).toMatchObject({ relay: url, follow: false });
    expect(off.followRate).toBeUndefined();
    expect(() => parseServeArgs([twin, "--relay", url, "--no-follow", "--monitor", "warn"])).toThrow(/--monitor goes with --follow URL/);
    expect(() => parseServeArgs([twin, "--follow", url, "--no-follow"])).toThrow(/contradict/);
    const other = "http://127.0.0.1:8082/robot";
    expect(parseServeArgs([twin, "--relay", url, "--follow", other])).toMatchObject({ relay: url, follow: other });
  });

  it("refuses a folder given twice (two robots on one base: every pose would collide)", () => {
    expect(() => parseServeArgs([join(dir, "twin"), join(dir, ".", "twin") + "/"])).toThrow(/twin folder given twice: .*twin \(copy the folder/);
  });
});

describe("a cell folder", () => {
  it("serves the twin folders inside a folder that is none itself, in name order; refuses one that holds none", () => {
    const cell = join(dir, "cell");
    for (const arm of ["warehouse", "arm"]) {
      mkdirSync(join(cell, arm), { recursive: true });
      writeFileSync(join(cell, arm, "td.json"), "{}");
      writeFileSync(join(cell, arm, "twin.json"), "{}");
    }
    mkdirSync(join(cell, "notes"), { recursive: true });
    expect(parseServeArgs([cell]).folders).toEqual([join(cell, "arm"), join(cell, "warehouse")]);
    expect(() => parseServeArgs([join(dir, "empty")])).toThrow(/is not a twin folder: no td\.json/);
  });
});

describe("serve --as", () => {
  it("takes DEVICE=FILE and an optional --as-map, both files resolved; refuses a malformed or misplaced one", () => {
    const twin = join(dir, "twin");
    const td = join(dir, "device.td.json");
    const map = join(dir, "device.map.json");
    writeFileSync(td, "{}");
    writeFileSync(map, "{}");
    expect(parseServeArgs([twin, "--as", `desk-arm=${td}`, "--as-map", map]).as).toEqual([{ name: "desk-arm", td, map }]);
    expect(parseServeArgs([twin, "--as", `desk-arm=${td}`]).as).toEqual([{ name: "desk-arm", td }]);
    expect(parseServeArgs([twin]).as).toBeUndefined();
    expect(() => parseServeArgs([twin, "--as-map", map])).toThrow(/--as-map goes with --as DEVICE=real-td\.json/);
    expect(() => parseServeArgs([twin, "--as", td])).toThrow(/--as must be DEVICE=real-td\.json/);
    expect(() => parseServeArgs([twin, "--as", `a/b=${td}`])).toThrow(/--as must be DEVICE=real-td\.json/);
    expect(() => parseServeArgs([twin, "--as", "desk-arm="])).toThrow(/--as must be DEVICE=real-td\.json/);
    expect(() => parseServeArgs([twin, "--as", `desk-arm=${join(dir, "nope.json")}`])).toThrow(/--as: file not found: .*nope\.json/);
    expect(() => parseServeArgs([twin, "--as", `desk-arm=${td}`, "--as-map", dir])).toThrow(/--as-map: file not found/);
    mkdirSync(join(dir, "twin2"), { recursive: true });
    writeFileSync(join(dir, "twin2", "td.json"), "{}");
    writeFileSync(join(dir, "twin2", "twin.json"), "{}");
    // several devices: a map each, by device; the twin each answers as is its map's (checked at start)
    const two = parseServeArgs([twin, join(dir, "twin2"), "--as", `desk-arm=${td}`, "--as", `belt=${td}`, "--as-map", `belt=${map}`]).as;
    expect(two).toEqual([{ name: "desk-arm", td }, { name: "belt", td, map }]);
    expect(() => parseServeArgs([twin, "--as", `a=${td}`, "--as", `a=${td}`])).toThrow(/--as names device a twice/);
    expect(() => parseServeArgs([twin, "--as", `a=${td}`, "--as", `b=${td}`, "--as-map", map])).toThrow(/--as-map must be DEVICE=map\.json/);
    expect(() => parseServeArgs([twin, "--as", `a=${td}`, "--as-map", `c=${map}`, "--as-map", map])).toThrow(/--as-map c: no --as c=\.\.\. names that device/);
  });
});
