/**
 * `serve --scan-source SRC`: the twins' scene kept current from a sensor's point clouds. Each frame (a
 * PLY, PCD or XYZ file) is turned into covers by the backend's `scene.fromScan` (the twins' robots, at
 * their joints now, removed), and the scanned obstacles (`scan-N`) are added, moved or removed through
 * the `SceneRecord`, so a change is the same event and `/live` message as a client's `addObstacle` /
 * `moveObstacle` / `removeObstacle` (`scan-changes.ts` decides which). Every state a robot moves through
 * is checked by the backend against the world as it is then, so a move under way meets the new scene.
 *
 * Sources: a folder (its newest cloud file, again whenever one is written), an `http(s)://` URL (fetched
 * every `periodMs` through the bounded `Outbound`: deadlines, size cap) or a `ws(s)://` URL (each binary
 * message a frame, `maxPayload` the size cap). One frame is built at a time; frames arriving meanwhile
 * are dropped but the latest. A frame that cannot be fetched, read or built leaves the last good scene
 * in place and is a fault: `status()` (in `/robwot.json`) and a warning, once per kind of failure
 * until a frame succeeds again.
 *
 * Covers are boxes or voxel boxes (no hull files): a still object's next box, which differs by the
 * sensor's noise, then lies inside the obstacle already there and changes nothing.
 *
 * A frame's robot points are told from obstacles by the robots' joints when it is built, so a frame is
 * used only when no robot moved within `STILL_MS` before it arrived nor while it was built; others are
 * skipped (counted): a robot's points seen where it no longer is would become an obstacle around it.
 */
import { createHash } from "node:crypto";
import { mkdtempSync, readdirSync, readFileSync, rmSync, statSync, watch, writeFileSync, type FSWatcher } from "node:fs";
import { tmpdir } from "node:os";
import { extname, join } from "node:path";
import { performance } from "node:perf_hooks";
import type { BackendSupervisor } from "@robwot/sim-client";
import type { Quaternion, Vec3 } from "@robwot/core";
import WebSocket from "ws";
import { redactUrl, type Outbound } from "./outbound.js";
import { scanChanges, type ScanBox } from "./scan-changes.js";
import type { SceneObstacle } from "./twin-folder.js";

export const CLOUD_EXTENSIONS = [".ply", ".pcd", ".xyz", ".txt"];
/** bytes of one frame at most: a cloud of the backend's point limit as binary float32 xyz is 120 MB */
export const MAX_FRAME_BYTES = 256 * 1024 * 1024;
/** ms the robots must have stood still before a frame arrives for it to be used */
export const STILL_MS = 300;

export interface ScanSourceOptions {
  source: string;
  /** the sensor's pose in the world (default: each frame's own viewpoint, else world coordinates) */
  position?: Vec3;
  orientation?: [number, number, number, number];
  /** m: the sensor's noise bound; every point is grown by it, and a written box by it again (hysteresis) */
  noise: number;
  /** ms between two fetches of an http(s) source */
  periodMs: number;
}

export interface ScanStatus {
  source: string;
  frames: number;
  /** ISO time of the last frame applied */
  lastFrame: string | null;
  /** the last failure, until a frame succeeds again */
  fault: string | null;
  /** frames not used because a robot moved around them */
  skipped: number;
  obstacles: string[];
}

/** What the scan source changes: the `SceneRecord`'s own run-time edits. */
export interface ScanWorld {
  addObstacle(backend: BackendSupervisor, input: SceneObstacle): Promise<unknown>;
  moveObstacle(backend: BackendSupervisor, pose: { name: string; position: Vec3; orientation: [number, number, number, number] }): Promise<unknown>;
  removeObstacle(backend: BackendSupervisor, name: string): Promise<unknown>;
}

const asQuat = (q: readonly number[]): Quaternion => ({ x: q[0]!, y: q[1]!, z: q[2]!, w: q[3]! });
const asArray = (q: Quaternion): [number, number, number, number] => [q.x, q.y, q.z, q.w];

/** The extension a frame's bytes say it has: PLY's magic, PCD's header, else XYZ text. */
export function sniffExtension(data: Buffer): string {
  const head = data.subarray(0, 64).toString("latin1");
  if (head.startsWith("ply")) return ".ply";
  if (/^(#\s*\.PCD|VERSION|FIELDS)/.test(head)) return ".pcd";
  return ".xyz";
}

export class ScanSource {
  private readonly dir = mkdtempSync(join(tmpdir(), "robwot-scan-"));
  private readonly boxes = new Map<string, ScanBox>();
  private next = 1;
  private frames = 0;
  private lastFrame: string | null = null;
  private fault: string | null = null;
  private busy = false;
  private latest: Buffer | null = null;
  private stopped = false;
  private timer: NodeJS.Timeout | null = null;
  private watcher: FSWatcher | null = null;
  private socket: WebSocket | null = null;
  private lastHash = "";
  private skipped = 0;
  /** bumped whenever a robot's joints change; when they last did (ms, `now`) */
  private motion = 0;
  private movedAt = Number.NEGATIVE_INFINITY;

  constructor(
    private readonly opts: ScanSourceOptions,
    private readonly backend: BackendSupervisor,
    private readonly world: ScanWorld,
    private readonly outbound: Outbound,
    private readonly warn: (message: string) => void = (m) => process.emitWarning(m, { code: "ROBWOT_SCAN" }),
    private readonly now: () => number = () => performance.now(),
  ) {}

  /** A robot's joints changed (the servient calls this on every twin's `joints`). */
  moved(): void {
    this.motion += 1;
    this.movedAt = this.now();
  }

  status(): ScanStatus {
    return { source: redactUrl(this.opts.source), frames: this.frames, lastFrame: this.lastFrame, fault: this.fault, skipped: this.skipped, obstacles: [...this.boxes.keys()] };
  }

  start(): void {
    const src = this.opts.source;
    if (/^https?:\/\//.test(src)) this.poll();
    else if (/^wss?:\/\//.test(src)) this.connect();
    else this.watchFolder(src);
  }

  stop(): void {
    this.stopped = true;
    if (this.timer) clearTimeout(this.timer);
    this.watcher?.close();
    this.socket?.terminate();
    rmSync(this.dir, { recursive: true, force: true });
  }

  /** A frame's bytes: built now, or kept as the latest while one is being built; skipped when a robot moved
   *  within `STILL_MS` before it. */
  offer(data: Buffer): boolean {
    if (this.now() - this.movedAt < STILL_MS) {
      this.skipped += 1;
      return false;
    }
    this.latest = data;
    if (!this.busy) void this.drain();
    return true;
  }

  private async drain(): Promise<void> {
    this.busy = true;
    try {
      while (this.latest && !this.stopped) {
        const data = this.latest;
        this.latest = null;
        await this.applyFrame(data);
      }
    } finally {
      this.busy = false;
    }
  }

  /** One frame: written to a file, covered by the backend, the changes applied; a failure kept as the fault. */
  async applyFrame(data: Buffer): Promise<void> {
    const file = join(this.dir, `frame${sniffExtension(data)}`);
    const motion = this.motion;
    try {
      if (data.length > MAX_FRAME_BYTES) throw new Error(`a frame of ${data.length} bytes is larger than ${MAX_FRAME_BYTES}`);
      writeFileSync(file, data);
      const scan = await this.backend.sim.sceneFromScan({
        clouds: [{ file, ...(this.opts.position ? { position: this.opts.position } : {}), ...(this.opts.orientation ? { orientation: this.opts.orientation } : {}) }],
        noise: this.opts.noise,
        shape: "box",
      });
      if (this.motion !== motion) {
        this.skipped += 1; // a robot moved while the frame was built: its points are not where it is
        return;
      }
      const frame: ScanBox[] = scan.obstacles.map((o) => {
        if (o.shape.type !== "box") throw new Error(`scene.fromScan answered a ${o.shape.type} cover; boxes were asked for`);
        return { name: o.name, size: o.shape.size as Vec3, position: o.position as Vec3, orientation: asQuat(o.orientation) };
      });
      await this.apply(frame);
      this.frames += 1;
      this.lastFrame = new Date().toISOString();
      this.fault = null;
    } catch (err) {
      this.failed(`frame from ${redactUrl(this.opts.source)} not applied, the last good scene kept: ${err instanceof Error ? err.message : String(err)}`);
    } finally {
      rmSync(file, { force: true });
    }
  }

  private async apply(frame: ScanBox[]): Promise<void> {
    const changes = scanChanges([...this.boxes.values()], frame, this.opts.noise, 0.5, () => `scan-${this.next++}`);
    for (const name of changes.remove) {
      await this.world.removeObstacle(this.backend, name);
      this.boxes.delete(name);
    }
    for (const m of changes.move) {
      await this.world.moveObstacle(this.backend, { name: m.name, position: m.position, orientation: asArray(m.orientation) });
      this.boxes.set(m.name, { ...this.boxes.get(m.name)!, position: m.position, orientation: m.orientation });
    }
    for (const b of changes.add) {
      await this.world.addObstacle(this.backend, { name: b.name, shape: { type: "box", size: b.size }, position: b.position, orientation: asArray(b.orientation) });
      this.boxes.set(b.name, b);
    }
  }

  private failed(message: string): void {
    const kind = message.replace(/\d+/g, "#");
    if (this.fault?.replace(/\d+/g, "#") !== kind) this.warn(message);
    this.fault = message;
  }

  private poll(): void {
    const tick = async (): Promise<void> => {
      try {
        const answer = await this.outbound.request(this.opts.source);
        if (answer.status !== 200) throw new Error(`GET answered ${answer.status} ${answer.statusText}`);
        const hash = createHash("sha256").update(answer.body).digest("hex");
        if (hash !== this.lastHash && this.offer(answer.body)) this.lastHash = hash;
      } catch (err) {
        this.failed(`scan source ${redactUrl(this.opts.source)} unheard: ${err instanceof Error ? err.message : String(err)}`);
      }
      if (!this.stopped) this.timer = setTimeout(() => void tick(), this.opts.periodMs);
    };
    void tick();
  }

  private connect(): void {
    const socket = (this.socket = new WebSocket(this.opts.source, { maxPayload: MAX_FRAME_BYTES, handshakeTimeout: 5000 }));
    socket.on("message", (data, binary) => void this.offer(binary ? Buffer.from(data as Buffer) : Buffer.from(String(data))));
    socket.on("error", (err) => this.failed(`scan source ${redactUrl(this.opts.source)} unheard: ${err.message}`));
    socket.on("close", () => {
      if (this.stopped) return;
      this.failed(`scan source ${redactUrl(this.opts.source)} closed the connection; reconnecting`);
      this.timer = setTimeout(() => this.connect(), Math.max(1000, this.opts.periodMs));
    });
  }

  private watchFolder(folder: string): void {
    let seen = "";
    const look = (): void => {
      try {
        const newest = readdirSync(folder)
          .filter((f) => CLOUD_EXTENSIONS.includes(extname(f).toLowerCase()))
          .map((f) => ({ f, s: statSync(join(folder, f)) }))
          .filter(({ s }) => s.isFile())
          .sort((a, b) => b.s.mtimeMs - a.s.mtimeMs)[0];
        if (!newest) return;
        const key = `${newest.f}:${newest.s.mtimeMs}:${newest.s.size}`;
        if (key === seen) return;
        if (newest.s.size > MAX_FRAME_BYTES) throw new Error(`${newest.f}: ${newest.s.size} bytes is larger than ${MAX_FRAME_BYTES}`);
        if (this.offer(readFileSync(join(folder, newest.f)))) seen = key; // a skipped frame is looked at again
      } catch (err) {
        this.failed(`scan folder ${folder}: ${err instanceof Error ? err.message : String(err)}`);
      }
    };
    look();
    this.watcher = watch(folder, () => look());
    // a writer renaming a finished file into place raises one event; one still writing raises more: a
    // periodic look catches a file whose last event came before it was complete
    const again = (): void => {
      if (this.stopped) return;
      look();
      this.timer = setTimeout(again, this.opts.periodMs);
    };
    this.timer = setTimeout(again, this.opts.periodMs);
  }
}
