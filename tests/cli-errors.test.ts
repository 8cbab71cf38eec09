/**
 * End to end: bad input to `robwot generate` (real child process, real backend where the error is found
 * there) exits non-zero with one clear `robwot: error:` line naming the cause, leaves no folder behind
 * and leaves an existing output untouched.
 */
import { existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { runCli, TINY_URDF } from "./cli-run.js";

let work: string;

beforeAll(() => {
  work = mkdtempSync(join(tmpdir(), "robwot-cli-errors-"));
  writeFileSync(join(work, "tiny.urdf"), TINY_URDF);
  // Line 4 has an unclosed <link> element.
  writeFileSync(join(work, "malformed.urdf"), '<?xml version="1.0"?>\n<robot name="broken">\n  <link name="a"/>\n  <link name="b">\n</robot>\n');
  writeFileSync(
    join(work, "fixed-only.urdf"),
    '<?xml version="1.0"?>\n<robot name="statue">\n  <link name="a"/>\n  <link name="b"/>\n' +
      '  <joint name="weld" type="fixed"><parent link="a"/><child link="b"/></joint>\n</robot>\n',
  );
  writeFileSync(join(work, "not-json.json"), '{"version": 1, "obstacles": [');
  writeFileSync(join(work, "bad-scene.json"), JSON.stringify({ version: 1, obstacles: [{ name: "b", shape: { type: "box", size: [0.1, -1, 0.1] }, position: [0.5, 0, 0.5] }] }));
  writeFileSync(join(work, "a-file"), "not a folder");
  // a slab the whole robot stands inside: every configuration touches it
  writeFileSync(join(work, "slab.json"), JSON.stringify({ version: 1, obstacles: [{ name: "slab", shape: { type: "box", size: [3, 3, 3] }, position: [0, 0, 0] }] }));
});
afterAll(() => rmSync(work, { recursive: true, force: true }));

/** The existing twin that every failing run targets: it must survive untouched. */
function makeExistingTwin(dir: string): void {
  mkdirSync(dir, { recursive: true });
  writeFileSync(join(dir, "twin.json"), '{"previous": true}');
  writeFileSync(join(dir, "td.json"), '{"title": "previous"}');
}

const leftovers = (): string[] => readdirSync(work).filter((n) => n.includes(".tmp-") || n.includes(".old-"));

const CASES: [string, () => string[], RegExp][] = [
  ["missing URDF file", () => ["generate", join(work, "nope.urdf")], /URDF file not found: .*nope\.urdf/],
  ["unknown example name", () => ["generate", "kuka_iiwaa"], /unknown example robot "kuka_iiwaa".*kuka_iiwa, franka_panda, xarm6/],
  ["malformed URDF", () => ["generate", join(work, "malformed.urdf")], /malformed\.urdf:\d+:\d+/],
  ["URDF without movable joints", () => ["generate", join(work, "fixed-only.urdf")], /movable/i],
  ["unknown --ee link", () => ["generate", join(work, "tiny.urdf"), "--ee", "hand"], /hand.*(turret|upper|fore|tip).*(turret|upper|fore|tip)/],
  ["missing scene file", () => ["generate", join(work, "tiny.urdf"), "--scene", join(work, "none.json")], /scene file not found/],
  ["scene that is not JSON", () => ["generate", join(work, "tiny.urdf"), "--scene", join(work, "not-json.json")], /not-json\.json is not valid JSON/],
  ["scene violating the schema", () => ["generate", join(work, "tiny.urdf"), "--scene", join(work, "bad-scene.json")], /bad-scene\.json.*(obstacles|size)/],
  ["bad --samples", () => ["generate", "kuka_iiwa", "--samples", "many"], /--samples must be an integer, got "many"/],
  ["bad --alpha", () => ["generate", "kuka_iiwa", "--alpha", "0"], /--alpha must be "auto" or a positive radius/],
  ["unknown option", () => ["generate", "kuka_iiwa", "--sampels", "10"], /sampels/],
  // "no collision-free configuration" names what touches and how often (the robot's links and the slab)
  ["a scene the robot touches everywhere", () => ["generate", join(work, "tiny.urdf"), "--scene", join(work, "slab.json")], /no collision-free configuration in 1000 samples.*in 40 configurations checked again: .*slab.*\(100 %\)/],
  ["--cluster with --workers", () => ["generate", "kuka_iiwa", "--cluster", "auto", "--workers", "2"], /--workers is for the local pool/],
  // with the cluster extra: nothing listens there; without it: the extra is named
  ["--cluster where no Ray cluster answers", () => ["generate", join(work, "tiny.urdf"), "--cluster", "127.0.0.1:1"], /Ray cluster at '127\.0\.0\.1:1'|cluster extra/],
];

describe("robwot generate with bad input", () => {
  it.each(CASES)("%s: non-zero exit, clear message, nothing left behind, old output intact", async (_name, args, message) => {
    const out = join(work, "existing-twin");
    makeExistingTwin(out);
    const a = args();
    const r = await runCli([...a.slice(0, 2), "--out", out, "--samples", "1000", ...a.slice(2)]);
    expect(r.code).not.toBe(0);
    expect(r.stderr).toMatch(/^robwot: error: /m);
    expect(r.stderr).toMatch(message);
    expect(r.stderr).not.toMatch(/unknown format|    at /);
    expect(r.stdout).toBe("");
    expect(readFileSync(join(out, "twin.json"), "utf8")).toBe('{"previous": true}');
    expect(readdirSync(out).sort()).toEqual(["td.json", "twin.json"]);
    expect(leftovers()).toEqual([]);
  });

  it.each([
    ["below a regular file", () => join(work, "a-file", "twin")],
    ["in /proc", () => "/proc/robwot-twin"],
  ])("an unwritable --out (%s) is refused before anything starts", async (_name, out) => {
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--out", out(), "--samples", "1000"]);
    expect(r.code).not.toBe(0);
    expect(r.stderr).toMatch(/^robwot: error: .*(not writable|cannot create|not a directory)/m);
    expect(leftovers()).toEqual([]);
  });

  it("refuses to replace a non-empty folder that is not a twin", async () => {
    const out = join(work, "my-documents");
    mkdirSync(out, { recursive: true });
    writeFileSync(join(out, "thesis.tex"), "precious");
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--out", out, "--samples", "1000"]);
    expect(r.code).not.toBe(0);
    expect(r.stderr).toMatch(/is not a twin folder/);
    expect(readFileSync(join(out, "thesis.tex"), "utf8")).toBe("precious");
  });

  it("--json reports the failure as JSON on stdout too", async () => {
    const r = await runCli(["generate", join(work, "tiny.urdf"), "--ee", "hand", "--json", "--out", join(work, "json-out"), "--samples", "1000"]);
    expect(r.code).not.toBe(0);
    const parsed = JSON.parse(r.stdout) as { ok: boolean; error: { code: string; message: string } };
    expect(parsed.ok).toBe(false);
    expect(parsed.error.code).toBe("E_UNKNOWN_LINK");
    expect(existsSync(join(work, "json-out"))).toBe(false);
  });

  it("unknown command and --help", async () => {
    const bad = await runCli(["genrate"]);
    expect(bad.code).toBe(2);
    expect(bad.stderr).toMatch(/unknown command "genrate" \(valid: generate, serve, demo, openapi, asyncapi, emulate, scene\)/);
    const help = await runCli(["generate", "--help"]);
    expect(help.code).toBe(0);
    expect(help.stdout).toMatch(/franka_panda/);
  });
});
