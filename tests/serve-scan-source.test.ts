/**
 * `serve --scan-source FOLDER`, end to end: a real cell (the table scene in a backend of its own) seen by
 * the backend's depth camera, each frame written into the folder; the served twin's scene follows it as
 * obstacles `scan-N` (/live `scene` messages, as addObstacle/moveObstacle/removeObstacle); the box moved
 * in the cell moves in the twin; a truncated frame keeps the last good scene and is the fault shown.
 */
import { mkdirSync, mkdtempSync, readFileSync, renameSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { launchBackend, type LaunchedBackend } from "@robwot/sim-client";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO } from "./cli-run.js";
import { generateTwin, http, live, type LiveClient } from "./serve-helpers.js";

let work: string;
let frames: string;
let cell: LaunchedBackend;
let s: RunningServient;
let watch: LiveClient;
let frameNo = 0;

interface Obstacle {
  name: string;
  position: number[];
}

/** One frame of the camera over the cell, written into the folder whole (renamed into place). */
async function frame(): Promise<void> {
  const tmp = join(work, `frame${++frameNo}.ply`);
  await cell.client.captureDepth({ file: tmp, position: [1.5, 0.2, 1.3], target: [0.4, 0, 0], noise: 0.0003, dropout: 0.02, seed: frameNo });
  renameSync(tmp, join(frames, `frame${frameNo}.ply`));
}

const near = (obstacles: Obstacle[], p: number[], d: number): Obstacle[] =>
  obstacles.filter((o) => o.name.startsWith("scan-") && Math.hypot(o.position[0]! - p[0]!, o.position[1]! - p[1]!) < d);

beforeAll(async () => {
  work = mkdtempSync(join(tmpdir(), "robwot-scan-src-"));
  frames = join(work, "frames");
  mkdirSync(frames);
  const dir = await generateTwin("kuka_iiwa", 3000);
  cell = await launchBackend();
  await cell.client.loadScene({ path: join(REPO, "examples/scenes/table.json") });
  s = await startServient({ twins: [dir], port: 0, realtime: 0, scanSource: { source: frames, noise: 0.004, periodMs: 100 } });
  watch = await live(`${s.liveUrl}?thing=${s.things[0]!.slug}`);
}, 300_000);

afterAll(async () => {
  watch?.close();
  await s?.stop();
  await cell?.stop();
  rmSync(work, { recursive: true, force: true });
});

it("builds the twin's scene from the first frame, then moves the box the cell moved", async () => {
  await frame();
  const first = await watch.waitFor((m) => m.type === "scene" && near(m.obstacles, [0.55, 0.25], 0.03).length > 0, 60_000);
  const table = (first.obstacles as Obstacle[]).filter((o) => o.name.startsWith("scan-"));
  expect(table.length).toBeGreaterThanOrEqual(2); // the table top and the box at least
  const box = near(first.obstacles, [0.55, 0.25], 0.03)[0]!;
  const index = (await http(`${s.url}/robwot.json`)).body as { scan: { frames: number; fault: string | null; obstacles: string[] } };
  expect(index.scan.frames).toBe(1);
  expect(index.scan.fault).toBeNull();

  await cell.client.moveObstacle({ name: "box", position: [0.6, -0.05, 0.09] });
  await frame();
  const moved = await watch.waitFor((m) => m.type === "scene" && near(m.obstacles, [0.6, -0.05], 0.03).length > 0, 60_000);
  expect(near(moved.obstacles, [0.55, 0.25], 0.03)).toEqual([]);
  // the box's obstacle was moved (same name), not removed and added again
  expect(near(moved.obstacles, [0.6, -0.05], 0.03).map((o) => o.name)).toContain(box.name);
}, 120_000);

it("keeps the last good scene when a frame is truncated, and shows the fault", async () => {
  const before = ((await http(`${s.url}/robwot.json`)).body as { scan: { obstacles: string[] } }).scan.obstacles;
  const last = readFileSync(join(frames, `frame${frameNo}.ply`));
  writeFileSync(join(work, "cut.ply"), last.subarray(0, last.length - 200));
  renameSync(join(work, "cut.ply"), join(frames, "zz-cut.ply"));
  let index: { scan: { fault: string | null; obstacles: string[] } } | null = null;
  for (let i = 0; i < 200; i++) {
    index = (await http(`${s.url}/robwot.json`)).body as typeof index;
    if (index!.scan.fault) break;
    await new Promise((r) => setTimeout(r, 50));
  }
  expect(index!.scan.fault).toMatch(/not applied, the last good scene kept/);
  expect(index!.scan.obstacles).toEqual(before);
}, 60_000);

it("takes its frames from an http source too, through the bounded outbound client", async () => {
  const { createServer } = await import("node:http");
  const latest = readFileSync(join(frames, "frame1.ply"));
  const sensor = createServer((_req, res) => {
    res.writeHead(200, { "content-type": "application/octet-stream" });
    res.end(latest);
  });
  await new Promise<void>((r) => sensor.listen(0, "127.0.0.1", () => r()));
  const port = (sensor.address() as { port: number }).port;
  const dir = await generateTwin("kuka_iiwa", 3000);
  const other = await startServient({ twins: [dir], port: 0, realtime: 0, scanSource: { source: `http://127.0.0.1:${port}/cloud.ply`, noise: 0.004, periodMs: 100 } });
  try {
    let index: { scan: { frames: number; fault: string | null; obstacles: string[] } } | null = null;
    for (let i = 0; i < 300 && !(index?.scan.frames); i++) {
      index = (await http(`${other.url}/robwot.json`)).body as typeof index;
      await new Promise((r) => setTimeout(r, 50));
    }
    await new Promise((r) => setTimeout(r, 600)); // several polls later: the same bytes are not a new frame
    index = (await http(`${other.url}/robwot.json`)).body as typeof index;
    expect(index!.scan.frames).toBe(1);
    expect(index!.scan.fault).toBeNull();
    expect(index!.scan.obstacles.length).toBeGreaterThanOrEqual(2);
  } finally {
    await other.stop();
    await new Promise((r) => sensor.close(r));
  }
}, 120_000);

it("takes its frames from a ws source: each binary message a frame", async () => {
  const { WebSocketServer } = await import("ws");
  const frame1 = readFileSync(join(frames, "frame1.ply"));
  const sensor = new WebSocketServer({ host: "127.0.0.1", port: 0 });
  // a sensor streams: a frame every 200 ms (a frame while the twin's robot has just moved is skipped)
  sensor.on("connection", (socket) => {
    const timer = setInterval(() => socket.send(frame1, { binary: true }), 200);
    socket.on("close", () => clearInterval(timer));
  });
  await new Promise<void>((r) => sensor.once("listening", () => r()));
  const port = (sensor.address() as { port: number }).port;
  const dir = await generateTwin("kuka_iiwa", 3000);
  const other = await startServient({ twins: [dir], port: 0, realtime: 0, scanSource: { source: `ws://127.0.0.1:${port}/`, noise: 0.004, periodMs: 100 } });
  try {
    let index: { scan: { frames: number; fault: string | null; obstacles: string[] } } | null = null;
    for (let i = 0; i < 300 && !(index?.scan.frames); i++) {
      index = (await http(`${other.url}/robwot.json`)).body as typeof index;
      await new Promise((r) => setTimeout(r, 50));
    }
    expect(index!.scan.frames).toBeGreaterThanOrEqual(1);
    expect(index!.scan.fault).toBeNull();
    expect(index!.scan.obstacles.length).toBeGreaterThanOrEqual(2);
  } finally {
    await other.stop();
    for (const c of sensor.clients) c.terminate();
    await new Promise((r) => sensor.close(r));
  }
}, 120_000);
