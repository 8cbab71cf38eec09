/**
 * Shared helpers of the servient end-to-end tests: twin folders made by the real CLI, a node-wot
 * consumer, plain fetch and /live WebSocket clients.
 */
import { cpSync, existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { createServer, type AddressInfo } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import WebSocket from "ws";
import { Servient } from "@node-wot/core";
import { HttpClientFactory } from "@node-wot/binding-http";
import { parseStl, parseWorkspaceCsv, REACHABILITY_REL, transformBounds, writeStl, writeWorkspaceCsv, type Vec3 } from "../packages/core/src/index.js";
import { runCli } from "./cli-run.js";
import { sleep, waitFor, within } from "./helpers/wait.js";

export { sleep, waitFor, within };

const cache = new Map<string, string>();

/** `robwot generate <robot> --samples N --out <tmp>` once per process; returns a private copy. */
export async function generateTwin(robot = "kuka_iiwa", samples = 3000, extra: string[] = []): Promise<string> {
  const key = [robot, samples, ...extra].join(" ");
  // ROBWOT_TEST_TWIN_<ROBOT>=<folder>: reuse a folder generated earlier (faster local iteration)
  let dir = process.env[`ROBWOT_TEST_TWIN_${robot.toUpperCase()}`] ?? cache.get(key);
  if (!dir || !existsSync(dir)) {
    dir = join(mkdtempSync(join(tmpdir(), "robwot-serve-gen-")), robot);
    const r = await runCli(["generate", robot, "--samples", String(samples), "--out", dir, ...extra], { timeoutMs: 300_000 });
    if (r.code !== 0) throw new Error(`robwot generate failed (${r.code}): ${r.stderr}`);
    cache.set(key, dir);
  }
  const copy = join(mkdtempSync(join(tmpdir(), "robwot-serve-twin-")), robot);
  cpSync(dir, copy, { recursive: true });
  return copy;
}

export interface HttpAnswer {
  status: number;
  type: string | null;
  headers: Headers;
  body: any;
}

export async function http(url: string, init: RequestInit = {}): Promise<HttpAnswer> {
  const r = await fetch(url, init);
  const text = await r.text();
  let body: unknown = text;
  try {
    body = JSON.parse(text);
  } catch {
    /* not JSON */
  }
  return { status: r.status, type: r.headers.get("content-type"), headers: r.headers, body };
}

export function invoke(base: string, action: string, body: unknown, headers: Record<string, string> = {}): Promise<HttpAnswer> {
  return http(`${base}/actions/${action}`, {
    method: "POST",
    headers: { "content-type": "application/json", ...headers },
    body: typeof body === "string" ? body : JSON.stringify(body),
  });
}

export async function consumer(credentials?: Record<string, unknown>): Promise<{ wot: WoT.WoT; stop(): Promise<void>; servient: Servient }> {
  const servient = new Servient();
  servient.addClientFactory(new HttpClientFactory());
  if (credentials) servient.addCredentials(credentials);
  const wot = (await servient.start()) as unknown as WoT.WoT;
  return { wot, servient, stop: () => servient.shutdown() };
}

export interface LiveClient {
  messages: any[];
  ws: WebSocket;
  waitFor(pred: (m: any) => boolean, timeoutMs?: number): Promise<any>;
  close(): void;
}

export async function live(url: string, headers: Record<string, string> = {}): Promise<LiveClient> {
  const ws = new WebSocket(url, { headers });
  const messages: any[] = [];
  const waiters: { pred: (m: any) => boolean; resolve: (m: any) => void }[] = [];
  ws.on("message", (d) => {
    const m = JSON.parse(d.toString());
    messages.push(m);
    for (const w of [...waiters]) {
      if (w.pred(m)) {
        waiters.splice(waiters.indexOf(w), 1);
        w.resolve(m);
      }
    }
  });
  await new Promise<void>((resolve, reject) => {
    ws.once("open", () => resolve());
    ws.once("error", reject);
  });
  return {
    messages,
    ws,
    waitFor: (pred, timeoutMs = 30_000) => {
      const seen = messages.find(pred);
      if (seen) return Promise.resolve(seen);
      return new Promise((resolve, reject) => {
        const t = setTimeout(() => reject(new Error("live message not received in time")), timeoutMs);
        waiters.push({ pred, resolve: (m) => (clearTimeout(t), resolve(m)) });
      });
    },
    close: () => ws.close(),
  };
}

export const KUKA_JOINTS = Array.from({ length: 7 }, (_, i) => `lbr_iiwa_joint_${i + 1}`);

export function kukaPose(values: number[]): Record<string, number> {
  return Object.fromEntries(KUKA_JOINTS.map((n, i) => [n, values[i] ?? 0]));
}

/** Seeded uniform numbers (mulberry32) and Box-Muller normals, from core. */
export { mulberry32 as rng, gaussian as gauss } from "@robwot/core";

export interface Rigid {
  s: number;
  R: number[][];
  t: Vec3;
}

export function rotZ(a: number): number[][] {
  return [
    [Math.cos(a), -Math.sin(a), 0],
    [Math.sin(a), Math.cos(a), 0],
    [0, 0, 1],
  ];
}

export const apply = (T: Rigid, p: Vec3): Vec3 =>
  [0, 1, 2].map((i) => T.s * (T.R[i]![0]! * p[0] + T.R[i]![1]! * p[1] + T.R[i]![2]! * p[2]) + T.t[i]!) as Vec3;

/** A copy of the twin whose robot stands at `pose` (rotation about z, then offset): the "physical" robot. */
export function placeTwin(src: string, yaw: number, offset: Vec3): void {
  const T: Rigid = { s: 1, R: rotZ(yaw), t: offset };
  const twinJson = JSON.parse(readFileSync(join(src, "twin.json"), "utf8"));
  twinJson.robot.basePosition = offset;
  twinJson.robot.baseOrientation = [0, 0, Math.sin(yaw / 2), Math.cos(yaw / 2)];
  writeFileSync(join(src, "twin.json"), JSON.stringify(twinJson));
  const cloud = parseWorkspaceCsv(readFileSync(join(src, "workspace.csv"), "utf8"));
  for (let i = 0; i < cloud.points.length; i += 3) cloud.points.set(apply(T, [cloud.points[i]!, cloud.points[i + 1]!, cloud.points[i + 2]!]), i);
  writeFileSync(join(src, "workspace.csv"), writeWorkspaceCsv(cloud));
  const stl = parseStl(readFileSync(join(src, "workspace.stl")));
  for (let i = 0; i < stl.triangles.length; i += 3) stl.triangles.set(apply(T, [stl.triangles[i]!, stl.triangles[i + 1]!, stl.triangles[i + 2]!]), i);
  writeFileSync(join(src, "workspace.stl"), writeStl(stl.triangles));
  // An axis-aligned voxel grid does not survive a rotation: the placed twin has no reachability map.
  rmSync(join(src, "reachability.csv"));
  const summary = JSON.parse(readFileSync(join(src, "workspace.json"), "utf8"));
  summary.bounds = transformBounds(summary.bounds, { scale: 1, rotation: T.R, translation: T.t });
  const bounds = transformBounds(summary.reachBounds, { scale: 1, rotation: T.R, translation: T.t });
  summary.reachBounds = bounds;
  writeFileSync(join(src, "workspace.json"), JSON.stringify(summary));
  const td = JSON.parse(readFileSync(join(src, "td.json"), "utf8"));
  td.links = td.links.filter((l: { rel: string }) => l.rel !== REACHABILITY_REL);
  for (const name of ["moveToCartesianPosition", "validateCartesianPosition"]) {
    const p = td.actions[name].input.properties;
    ["x", "y", "z"].forEach((k, i) => {
      p[k].minimum = bounds.min[i];
      p[k].maximum = bounds.max[i];
    });
  }
  writeFileSync(join(src, "td.json"), JSON.stringify(td));
}


/** Polls motionStatus until `state` (e.g. "moving" once validation is done and the motion runs). */
export async function waitState(thingBase: string, state: string, timeoutMs = 30_000, headers: Record<string, string> = {}): Promise<void> {
  await waitFor(async () => (await http(`${thingBase}/properties/motionStatus`, { headers })).body?.state === state, {
    timeoutMs,
    what: `motionStatus "${state}"`,
  });
}

/** Polls getJointPosition until `joint` is more than `by` rad away from `from` (the motion has really
 * begun: "moving" is reported from acceptance, before the backend has planned). */
export async function waitMoved(thingBase: string, joint: string, from: number, by = 0.02, timeoutMs = 30_000): Promise<void> {
  await waitFor(async () => Math.abs(((await http(`${thingBase}/properties/getJointPosition`)).body?.[joint] ?? from) - from) > by, {
    timeoutMs,
    what: `${joint} moving ${by} rad`,
  });
}

/** Polls getJointPosition until every joint of `joints` is within `tolerance` (a following twin reaches
 * what it mirrors: it follows a difference above FOLLOW_TOLERANCE, 1e-4 rad). */
export async function waitJoints(thingBase: string, joints: Record<string, number>, tolerance = 2e-4, timeoutMs = 30_000): Promise<void> {
  let q: Record<string, number> = {};
  const near = async (): Promise<boolean> => {
    q = (await http(`${thingBase}/properties/getJointPosition`)).body as Record<string, number>;
    return Object.entries(joints).every(([j, v]) => Math.abs((q[j] ?? NaN) - v) <= tolerance);
  };
  await waitFor(near, { timeoutMs, what: `the twin at ${JSON.stringify(joints)}` }).catch((e: Error) => {
    throw new Error(`${e.message}: it is at ${JSON.stringify(q)}`);
  });
}

/** Polls getJointPosition until two reads in a row agree within `tolerance` on every joint (a lagging
 * report has caught up with the joints it follows; between two reads the reporter has stepped at least
 * once); returns the last read. */
export async function waitSettled(thingBase: string, tolerance = 1e-7, timeoutMs = 30_000): Promise<Record<string, number>> {
  let last: Record<string, number> | null = null;
  return waitFor(
    async () => {
      const q = (await http(`${thingBase}/properties/getJointPosition`)).body as Record<string, number>;
      const still = last !== null && Object.entries(q).every(([j, v]) => Math.abs(v - (last?.[j] ?? NaN)) <= tolerance);
      last = q;
      return still ? q : null;
    },
    { timeoutMs, what: `the joints of ${thingBase} settling` },
  );
}

/** Adds a box of edge `size` to the twin where its tool will be once joint 1 has turned `angle` rad from now
 * (the KUKA's joint 1 turns about the world's z axis through the origin). */
export async function boxOnJoint1Arc(thingBase: string, angle: number, size: number): Promise<void> {
  const p = (await http(`${thingBase}/properties/getCartesianPosition`)).body;
  const [c, s] = [Math.cos(angle), Math.sin(angle)];
  const box = { name: "fixture", shape: { type: "box", size: [size, size, size] }, position: [c * p.x - s * p.y, s * p.x + c * p.y, p.z] };
  const r = await invoke(thingBase, "addObstacle", box);
  if (r.status !== 200) throw new Error(`addObstacle answered ${r.status}: ${JSON.stringify(r.body)}`);
}

/**
 * A stand-in physical robot: a KUKA twin whose URDF joint velocities are 20x lower than the model its
 * relaying twin simulates, served in real time, so a relayed motion runs for many seconds there.
 */
export async function slowPhysicalTwin(): Promise<string> {
  const dir = await generateTwin("kuka_iiwa", 3000);
  const urdf = join(dir, "robot.urdf");
  writeFileSync(urdf, readFileSync(urdf, "utf8").replaceAll('velocity="10"', 'velocity="0.5"'));
  return dir;
}

/** A port nothing listens on (bound, then released). */
export function freePort(): Promise<number> {
  return new Promise((resolve) => {
    const srv = createServer().listen(0, "127.0.0.1", () => {
      const { port } = srv.address() as AddressInfo;
      srv.close(() => resolve(port));
    });
  });
}

/**
 * What `start(port)` settles to on a port nothing listened on a moment before: started again on another
 * such port while it fails because something took the port meanwhile (another test process binding port 0
 * may be given it), at most `tries` times.
 */
export async function onFreePort<T>(start: (port: number) => Promise<T>, tries = 5): Promise<{ port: number; value?: T; error?: Error }> {
  for (let i = 1; ; i++) {
    const port = await freePort();
    try {
      return { port, value: await start(port) };
    } catch (err) {
      const error = err instanceof Error ? err : new Error(String(err));
      if (i < tries && error.message.includes(`port ${port} on 127.0.0.1 is in use`)) continue;
      return { port, error };
    }
  }
}
