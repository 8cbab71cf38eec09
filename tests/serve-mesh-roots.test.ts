/**
 * Run-time mesh obstacles (addObstacle) come only from the twin folder and `--mesh-root` folders: any
 * other path is refused with 403 whether the file exists or not (no file-existence oracle); a hostile
 * mesh inside a root is refused by the backend's parser with 422-class JSON naming the reason, and the
 * twin keeps serving. Real servient, real backend, real HTTP.
 */
import { copyFileSync, mkdirSync, mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO } from "./cli-run.js";
import { generateTwin, http, invoke } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
let twinDir: string;
const extra = mkdtempSync(join(tmpdir(), "robwot-mesh-root-"));
const outside = mkdtempSync(join(tmpdir(), "robwot-outside-"));
const CUBE = join(REPO, "sim-backend", "tests", "models", "meshes", "cube.stl");

beforeAll(async () => {
  twinDir = await generateTwin("kuka_iiwa", 3000);
  mkdirSync(join(twinDir, "parts"));
  copyFileSync(CUBE, join(twinDir, "parts", "cube.stl"));
  copyFileSync(CUBE, join(extra, "crate.stl"));
  copyFileSync(CUBE, join(outside, "secret.stl"));
  writeFileSync(join(extra, "lying.stl"), Buffer.concat([Buffer.alloc(80), Buffer.from([0xe8, 0x03, 0, 0])]));
  s = await startServient({ twins: [twinDir], port: 0, realtime: 0, meshRoots: [extra] });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

const mesh = (name: string, file: string): object => ({ name, shape: { type: "mesh", file }, position: [1.5, 1.5, 0] });

describe("mesh roots", () => {
  it("accepts a file relative to the twin folder, and one in a --mesh-root (relative or absolute)", async () => {
    expect((await invoke(base, "addObstacle", mesh("a", "parts/cube.stl"))).status).toBe(200);
    expect((await invoke(base, "addObstacle", mesh("b", "crate.stl"))).status).toBe(200);
    expect((await invoke(base, "addObstacle", mesh("c", join(extra, "crate.stl")))).status).toBe(200);
  });

  it.each([
    ["an existing file elsewhere", () => join(outside, "secret.stl")],
    ["a missing file elsewhere", () => join(outside, "nothing.stl")],
    ["a system file", () => "/etc/hostname"],
    ["a path climbing out of the root", () => "../../../../etc/hostname"],
  ])("refuses %s with the same 403 (no existence oracle)", async (_what, file) => {
    const r = await invoke(base, "addObstacle", mesh("x", file()));
    expect(r.status).toBe(403);
    expect(r.body.code).toBe("E_PATH_ESCAPE");
    expect(r.body.message).not.toMatch(/not found|exist/i);
  });

  it("refuses a hostile mesh inside a root by its content and keeps serving", async () => {
    const r = await invoke(base, "addObstacle", mesh("y", "lying.stl"));
    expect(r.status).toBe(422);
    expect(r.body.code).toBe("E_MESH");
    expect(r.body.message).toMatch(/1000 triangles/);
    expect((await http(`${base}/properties/motionStatus`)).status).toBe(200);
    expect(s.backend.restarts).toBe(0);
  });
});
