/**
 * `robwot emulate --camera`: the emulated cell seen by a depth camera, served as the `pointCloud` property.
 * The real CLI (its own backend) with examples/scenes/table.json (whose robot "kuka" stands on the emulated
 * robot's base: left out, warned), real HTTP: the TD declares the property with an octet-stream form; a
 * frame is a binary PLY whose points, placed by its viewpoint comment, lie on the table top and on the box;
 * a frame after a joint move sees the robot where it moved; consecutive frames differ (a seed each);
 * `--auth` guards it. Also: one capture at a time (a fake backend), the twin folder's own scene by
 * default, a scene naming "emulated" refused, and option errors refused before anything starts.
 */
import { spawn, type ChildProcess } from "node:child_process";
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { quat, quatRotate, type Vec3 } from "../packages/core/src/index.js";
import { DepthCamera } from "../packages/servient/src/emulate-camera.js";
import { startEmulator } from "../packages/servient/src/index.js";
import { CLI, REPO, runCli } from "./cli-run.js";
import { generateTwin, http, invoke, kukaPose } from "./serve-helpers.js";

const TABLE = join(REPO, "examples", "scenes", "table.json");
const CAMERA = ["--camera", "1.5,0.2,1.3:0.4,0,0"];
const AUTH = { authorization: `Basic ${Buffer.from("u:p").toString("base64")}` };

let dir: string;
let work: string;
let child: ChildProcess;
let exited: Promise<number | null>;
let stderr = "";
let tdUrl: string;

/** The emulator as the CLI runs it; resolves with its TD URL once it serves (`--json`'s line). */
function emulate(args: string[]): Promise<string> {
  child = spawn(process.execPath, [CLI, "emulate", ...args, "--port", "0", "--json"], { cwd: REPO, stdio: ["ignore", "pipe", "pipe"] });
  child.stderr!.on("data", (d: Buffer) => (stderr += d.toString()));
  exited = new Promise((resolve) => child.on("close", (code) => resolve(code)));
  let stdout = "";
  return new Promise((resolve, reject) => {
    child.stdout!.on("data", (d: Buffer) => {
      stdout += d.toString();
      const nl = stdout.indexOf("\n");
      if (nl >= 0) resolve((JSON.parse(stdout.slice(0, nl)) as { tdUrl: string }).tdUrl);
    });
    void exited.then((code) => reject(new Error(`robwot emulate exited (${code}) before serving:\n${stderr}`)));
  });
}

beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
  work = mkdtempSync(join(tmpdir(), "robwot-emulate-camera-test-"));
  tdUrl = await emulate([dir, ...CAMERA, "--scene", TABLE, "--auth", "basic:u:p"]);
});
afterAll(async () => {
  child?.kill("SIGINT");
  await exited;
  rmSync(work, { recursive: true, force: true });
});

interface Frame {
  header: string;
  /** the points in the world frame (placed by the viewpoint comment) */
  points: Vec3[];
}

/** A binary little-endian PLY of float32 x y z, placed in the world by its viewpoint comment. */
function parsePly(buf: Buffer): Frame {
  const end = buf.indexOf("end_header\n") + "end_header\n".length;
  const header = buf.subarray(0, end).toString("latin1");
  const count = Number(/^element vertex (\d+)$/m.exec(header)?.[1]);
  const view = (/^comment robwot viewpoint (.+)$/m.exec(header)?.[1] ?? "").split(" ").map(Number);
  const [at, q] = [view.slice(0, 3), quat(view.slice(3))];
  const points = Array.from({ length: count }, (_, i): Vec3 => {
    const p = quatRotate(q, [buf.readFloatLE(end + 12 * i), buf.readFloatLE(end + 12 * i + 4), buf.readFloatLE(end + 12 * i + 8)]);
    return [p[0] + at[0]!, p[1] + at[1]!, p[2] + at[2]!];
  });
  return { header, points };
}

async function frame(url: string, headers: Record<string, string> = AUTH): Promise<{ bytes: Buffer; frame: Frame }> {
  const r = await fetch(`${url}/properties/pointCloud`, { headers });
  expect(r.status).toBe(200);
  expect(r.headers.get("content-type")).toBe("application/octet-stream");
  const bytes = Buffer.from(await r.arrayBuffer());
  return { bytes, frame: parsePly(bytes) };
}

/** Points on the table top (its surface at z -0.01 m), on table.json's box (0.1 x 0.1 x 0.2 m at x 0.55,
 *  y 0.25, turned 0.3 rad; its top at z 0.19 m), and above 0.5 m within 0.15 m of the robot's base axis. */
function census(points: Vec3[]): { table: number; box: number; boxTop: number; above: number; aboveBase: number } {
  const [c, s] = [Math.cos(-0.3), Math.sin(-0.3)];
  const onBox = points.filter(([x, y, z]) => {
    const [dx, dy] = [x - 0.55, y - 0.25];
    return Math.abs(c * dx - s * dy) < 0.06 && Math.abs(s * dx + c * dy) < 0.06 && z > 0 && z < 0.2;
  });
  const above = points.filter((p) => p[2] > 0.5);
  return {
    table: points.filter((p) => Math.abs(p[2] + 0.01) < 0.01).length,
    box: onBox.length,
    boxTop: onBox.filter((p) => Math.abs(p[2] - 0.19) < 0.01).length,
    above: above.length,
    aboveBase: above.filter((p) => Math.hypot(p[0], p[1]) < 0.15).length,
  };
}

describe("robwot emulate --camera", () => {
  it("declares pointCloud in its TD: read-only, not observable, an octet-stream form describing the PLY", async () => {
    const td = (await http(tdUrl, { headers: AUTH })).body;
    const p = td.properties.pointCloud;
    expect(p).toMatchObject({ readOnly: true, observable: false });
    expect(p.description).toMatch(/binary PLY/);
    expect(p.forms).toHaveLength(1);
    expect(p.forms[0]).toMatchObject({ contentType: "application/octet-stream", op: ["readproperty"] });
    expect(p.forms[0].href).toBe(`${tdUrl}/properties/pointCloud`);
    // every property of readallproperties has a JSON value: the frame is read on its own
    expect(Object.keys((await http(`${tdUrl}/properties`, { headers: AUTH })).body).sort()).toEqual(["getJointPosition", "motionStatus"]);
    expect(stderr).toMatch(/the scene .*table\.json places robot "kuka" on the emulated robot's base: taken to be the emulated robot itself \(left out\)/);
  });

  it("answers a binary PLY whose points, placed by its viewpoint, lie on the table top and the box", async () => {
    const { frame: f } = await frame(tdUrl);
    expect(f.header).toMatch(/^ply\nformat binary_little_endian 1\.0\n/);
    expect(f.header).toMatch(/^comment robwot viewpoint 1\.5 0\.2 1\.3 /m);
    expect(f.points.length).toBeGreaterThan(1000);
    const n = census(f.points);
    expect(n.table).toBeGreaterThan(1000);
    expect(n.box).toBeGreaterThan(50);
    expect(n.boxTop).toBeGreaterThan(20);
    // the robot stands upright at home: its links rise above 0.5 m on its base axis (the scene's "kuka"
    // on the same base is left out, so only the emulated robot can be there)
    expect(n.aboveBase).toBeGreaterThan(100);
  });

  it("sees the robot where a move put it; consecutive frames differ by their noise", async () => {
    const before = census((await frame(tdUrl)).frame.points);
    const r = await invoke(tdUrl, "moveToJointPosition", { joints: kukaPose([0, 1.2, 0, 0, 0, 0, 0]), speed: 0.5 }, AUTH);
    expect(r.status, JSON.stringify(r.body)).toBe(200);
    expect(r.body.status).toBe("reached");
    const [a, b] = [await frame(tdUrl), await frame(tdUrl)];
    const after = census(a.frame.points);
    // leaning 1.2 rad at its shoulder, nothing of the robot is left above 0.5 m on its base axis
    expect(after.aboveBase).toBe(0);
    expect(after.above).not.toBe(before.above);
    expect(after.boxTop).toBeGreaterThan(20);
    expect(a.bytes.equals(b.bytes)).toBe(false);
  });

  it("--auth guards it: without or with wrong credentials 401", async () => {
    for (const headers of [{}, { authorization: `Basic ${Buffer.from("u:wrong").toString("base64")}` }]) {
      const r = await http(`${tdUrl}/properties/pointCloud`, { headers });
      expect(r.status).toBe(401);
      expect(r.body.code).toBe("E_UNAUTHORIZED");
    }
  });
});

describe("the camera's scene", () => {
  it("is the twin folder's own scene.json by default", async () => {
    const box = (JSON.parse(readFileSync(TABLE, "utf8")) as { obstacles: { name: string }[] }).obstacles.filter((o) => o.name === "box");
    writeFileSync(join(dir, "scene.json"), JSON.stringify({ version: 1, obstacles: box, robots: [] }));
    const robot = await startEmulator({ folder: dir, port: 0, camera: { position: [1.5, 0.2, 1.3], target: [0.4, 0, 0], width: 320, height: 240, noise: 0.001, dropout: 0.01 } });
    try {
      const n = census((await frame(robot.tdUrl, {})).frame.points);
      expect(n.boxTop).toBeGreaterThan(20);
      // no table in this cell: nothing at the table top's height but the robot's base
      expect(n.table).toBeLessThan(n.box);
    } finally {
      await robot.stop();
    }
  });

  it("naming anything 'emulated' is refused, naming what", async () => {
    const scene = join(work, "clash.json");
    writeFileSync(scene, JSON.stringify({ version: 1, obstacles: [{ name: "emulated", shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [1, 1, 0.05] }] }));
    const r = await runCli(["emulate", dir, ...CAMERA, "--scene", scene, "--port", "0"]);
    expect(r.code).toBe(1);
    expect(r.stderr).toMatch(/the scene .*clash\.json names its obstacle "emulated", the emulated robot's id: rename it in the scene/);
  });

  // (every option's refusals: packages/cli/src/commands/emulate.test.ts)
  it.each([
    [["--scene", TABLE], /--scene goes with --camera/],
    [[...CAMERA, "--camera-size", "640"], /--camera-size must be WxH, each 1 to 4096 pixels/],
  ])("refuses %j before starting anything", async (args, message) => {
    const r = await runCli(["emulate", dir, ...args, "--port", "0"]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(message);
    expect(r.stdout).toBe("");
  });
});

describe("one capture at a time", () => {
  it("a request while a capture runs gets its frame; the next request a new capture with the next seed", async () => {
    const calls: { seed: number; joints: number[] }[] = [];
    let release = (): void => undefined;
    let joints: number[] = [];
    const sim = {
      setJointPositions: async (p: { positions: number[] }) => void (joints = p.positions),
      captureDepth: (p: { file: string; seed: number }) => {
        calls.push({ seed: p.seed, joints });
        writeFileSync(p.file, `frame ${p.seed}`);
        return new Promise<void>((resolve) => (release = resolve));
      },
    };
    let q = [0.1];
    const camera = new DepthCamera(sim as never, { position: [1, 0, 1], target: [0, 0, 0], width: 4, height: 3, noise: 0, dropout: 0 }, () => q, 7);
    try {
      const first = camera.frame();
      const second = camera.frame();
      expect(second).toBe(first);
      await new Promise((r) => setImmediate(r));
      release();
      const [a, b] = await Promise.all([first, second]);
      expect(a.body.toString()).toBe("frame 7");
      expect(b).toBe(a);
      q = [0.2];
      const next = camera.frame();
      await new Promise((r) => setImmediate(r));
      release();
      expect((await next).body.toString()).toBe("frame 8");
      expect(calls).toEqual([
        { seed: 7, joints: [0.1] },
        { seed: 8, joints: [0.2] },
      ]);
    } finally {
      camera.close();
    }
  });
});
