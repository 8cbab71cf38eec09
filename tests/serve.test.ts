/**
 * End to end: `robwot generate` -> servient on port 0 -> node-wot consumer, plain fetch and /live.
 * Every affordance, the served files and TD, bad input (400 JSON, state unchanged), busy (409),
 * stop mid-motion, validation against obstacles (422) and a collision mid-motion.
 */
import { mkdirSync, mkdtempSync, readFileSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { validateThingDescription, withAbsoluteForms } from "../packages/core/src/index.js";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { ServerRequests } from "./helpers/server-requests.js";
import { consumer, generateTwin, http, invoke, kukaPose, live, waitFor, waitMoved, waitState, type LiveClient } from "./serve-helpers.js";

let s: RunningServient;
let twinDir: string;
let base: string;
let slug: string;
const HOME = kukaPose([0, 0, 0, 0, 0, 0, 0]);
const BENT = kukaPose([0.3, 0.5, 0, -1.2, 0, 0.6, 0]);

beforeAll(async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  twinDir = dir;
  const viewerDir = mkdtempSync(join(tmpdir(), "robwot-viewer-"));
  mkdirSync(join(viewerDir, "assets"));
  writeFileSync(join(viewerDir, "index.html"), "<!doctype html><title>viewer</title>");
  writeFileSync(join(viewerDir, "assets", "app.js"), "export {};");
  s = await startServient({ twins: [dir], port: 0, realtime: 1, viewerDir });
  slug = s.things[0]!.slug;
  base = `${s.url}/${slug}`;
});
afterAll(async () => s?.stop());

const readJoints = async (): Promise<Record<string, number>> => (await http(`${base}/properties/getJointPosition`)).body;
const readStatus = async (): Promise<any> => (await http(`${base}/properties/motionStatus`)).body;

describe("TD and files", () => {
  it("serves the on-disk td.json itself: only the address (base, form hrefs, /live link) and security differ", async () => {
    const served = (await http(base)).body;
    const disk = withAbsoluteForms(JSON.parse(readFileSync(join(twinDir, "td.json"), "utf8")), `${base}/`);
    for (const l of disk.links) if (l.rel === "robwot:live") l.href = s.liveUrl;
    const strip = ({ security: _s, securityDefinitions: _d, ...rest }: Record<string, unknown>): Record<string, unknown> => rest;
    expect(strip(served)).toEqual(strip(disk));
  });

  it("serves the TD with the real base, the /live link and every affordance", async () => {
    const r = await http(base);
    expect(r.status).toBe(200);
    expect(r.type).toContain("application/td+json");
    const td = r.body;
    expect(td.base).toBe(`${base}/`);
    expect(Object.keys(td.properties).sort()).toEqual(["calibration", "getCartesianPosition", "getJointPosition", "motionStatus", "objects", "physicalState"]);
    expect(Object.keys(td.actions)).toEqual(
      expect.arrayContaining(["moveToJointPosition", "moveToCartesianPosition", "validateJointPosition", "validateCartesianPosition", "stop", "calibrate", "addObstacle", "moveObstacle", "removeObstacle"]),
    );
    // the private /live protocol is a link: no form claims a standard operation over it
    expect(td.links).toContainEqual({ rel: "robwot:live", href: s.liveUrl, type: "application/json" });
    const forms = [...Object.values(td.properties), ...Object.values(td.events)].flatMap((a: any) => a.forms);
    expect(forms.filter((f: any) => !String(f.href).startsWith("http") && /^wss?:/.test(f.href))).toEqual([]);
    expect(td.securityDefinitions[td.security].scheme).toBe("nosec");
    const official = await validateThingDescription(td);
    expect(official.errors).toEqual([]);
    expect(official.valid).toBe(true);
    const index = await http(`${s.url}/robwot.json`);
    expect(index.body.things[0].tdUrl).toBe(base);
    expect(index.body.live).toBe(s.liveUrl);
    expect(index.body.security).toBe("nosec");
  });

  it.each([
    ["robot.urdf", "application/urdf+xml"],
    ["workspace.csv", "text/csv"],
    ["workspace.stl", "model/stl"],
    ["workspace.json", "application/json"],
    ["scene.json", "application/json"],
    ["twin.json", "application/json"],
  ])("serves %s as %s at the TD's link href", async (file, type) => {
    const td = (await http(base)).body;
    const link = td.links.find((l: any) => l.href === file);
    expect(link?.type ?? type).toBe(type);
    const r = await fetch(new URL(file, td.base));
    expect(r.status).toBe(200);
    expect(r.headers.get("content-type")).toBe(type);
    expect((await r.arrayBuffer()).byteLength).toBeGreaterThan(10);
  });

  it.each(["/%2e%2e/%2e%2e/etc/passwd", "/..%2ftwin.json", "/calibration.json", "/td.json", "/meshes/../../../etc/passwd"])("refuses %s outside the allowed files", async (p) => {
    const r = await fetch(`${base}${p}`);
    expect([400, 404]).toContain(r.status);
  });
});

describe("viewer bundle", () => {
  it.each([
    ["/viewer/", "text/html"],
    ["/viewer/assets/app.js", "text/javascript"],
  ])("serves %s as %s", async (p, type) => {
    const r = await fetch(`${s.url}${p}`);
    expect(r.status).toBe(200);
    expect(r.headers.get("content-type")).toContain(type);
  });
  it("keeps requests inside the bundle folder", async () => {
    expect((await fetch(`${s.url}/viewer/..%2f..%2fetc%2fpasswd`)).status).toBe(404);
    expect((await fetch(`${s.url}/viewer/nope.js`)).status).toBe(404);
    expect((await fetch(`${s.url}/viewer?thing=${slug}`, { redirect: "manual" })).headers.get("location")).toBe(`/viewer/?thing=${slug}`);
  });
});

describe("affordances through a node-wot consumer", () => {
  it("reads every property and invokes the moves and validations", async () => {
    const c = await consumer();
    try {
      const thing = await c.wot.consume(await c.wot.requestThingDescription(base));
      const joints = (await (await thing.readProperty("getJointPosition")).value()) as Record<string, number>;
      expect(Object.keys(joints)).toHaveLength(7);
      const pose = (await (await thing.readProperty("getCartesianPosition")).value()) as any;
      expect(pose.z).toBeGreaterThan(1);
      expect(((await (await thing.readProperty("motionStatus")).value()) as any).state).toBeDefined();
      expect(await (await thing.readProperty("calibration")).value()).toEqual({ active: false });

      const moved = (await (await thing.invokeAction("moveToJointPosition", { joints: BENT }))!.value()) as any;
      expect(moved.status).toBe("reached");
      for (const [k, v] of Object.entries(BENT)) expect(moved.joints[k]).toBeCloseTo(v, 4);
      const after = (await (await thing.readProperty("getJointPosition")).value()) as Record<string, number>;
      expect(after.lbr_iiwa_joint_4).toBeCloseTo(-1.2, 4);

      const target = { x: moved.position.x, y: moved.position.y - 0.05, z: moved.position.z - 0.05 };
      const report = (await (await thing.invokeAction("validateCartesianPosition", target))!.value()) as any;
      expect(report.valid).toBe(true);
      expect(report.checks.insideWorkspace.ok).toBe(true);
      expect(report.checks.ik.ok).toBe(true);
      expect(report.checks.path.ok).toBe(true);
      const jr = (await (await thing.invokeAction("validateJointPosition", { joints: HOME }))!.value()) as any;
      expect(jr.valid).toBe(true);
      const cart = (await (await thing.invokeAction("moveToCartesianPosition", target))!.value()) as any;
      expect(cart.status).toBe("reached");
      expect(cart.positionError).toBeLessThan(1e-3);
      expect(cart.duration).toBeGreaterThan(0);
      const stop = (await (await thing.invokeAction("stop"))!.value()) as any;
      expect(stop).toEqual({ stopped: false, simulation: { ok: true } });
    } finally {
      await c.stop();
    }
  });

  it("delivers joint updates to a node-wot long-poll observer while moving", async () => {
    const c = await consumer();
    try {
      const thing = await c.wot.consume(await c.wot.requestThingDescription(base));
      const seen: Record<string, number>[] = [];
      const requests = new ServerRequests();
      try {
        // the move starts once the servient holds the observer's long poll
        const polled = requests.next((q) => (q.url ?? "").includes("/properties/getJointPosition/observable"), "the long poll");
        const sub = await thing.observeProperty("getJointPosition", async (d) => void seen.push((await d.value()) as Record<string, number>));
        await polled;
        const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([-0.8, 0.3, 0, -1.0, 0, 0.5, 0]), speed: 0.1 });
        expect(r.status).toBe(200);
        const during = (j: Record<string, number>): boolean => j.lbr_iiwa_joint_1! < -0.05 && j.lbr_iiwa_joint_1! > -0.79;
        await waitFor(() => seen.length >= 2 && seen.some(during), { what: "two values, one on the way" }).catch(() => undefined);
        await sub.stop();
        expect(seen.length).toBeGreaterThanOrEqual(2);
        expect(seen.some(during)).toBe(true);
      } finally {
        requests.close();
      }
    } finally {
      await c.stop();
    }
  });

  it("streams joints and status over /live while moving (>= 20 Hz)", async () => {
    const ws: LiveClient = await live(s.liveUrl);
    try {
      ws.ws.send(JSON.stringify({ subscribe: slug }));
      await ws.waitFor((m) => m.type === "status");
      const start = ws.messages.length;
      const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([1.0, 0.3, 0, -1.0, 0, 0.5, 0]), speed: 0.2 });
      expect(r.status).toBe(200);
      const joints = ws.messages.slice(start).filter((m) => m.type === "joints");
      const simSpan = joints.at(-1).time - joints[0].time;
      expect(simSpan).toBeGreaterThan(0);
      expect(joints.length / Math.max(r.body.duration, 1e-3)).toBeGreaterThanOrEqual(20);
      expect(joints[0]).toMatchObject({ thing: slug, type: "joints" });
      expect(Object.keys(joints[0].position)).toEqual(["x", "y", "z"]);
      expect(ws.messages.slice(start).some((m) => m.type === "status" && m.state === "moving")).toBe(true);
      await ws.waitFor((m) => m.type === "status" && m.state === "idle");
    } finally {
      ws.close();
    }
  });
});

describe("bad input -> 400 JSON, state unchanged", () => {
  const cases: [string, string, unknown][] = [
    ["joints of the wrong type", "moveToJointPosition", { joints: "up" }],
    ["a joint out of range", "moveToJointPosition", { joints: { ...HOME, lbr_iiwa_joint_2: 7 } }],
    ["an unknown joint", "moveToJointPosition", { joints: { ...HOME, elbow: 0.1 } }],
    ["a missing joint", "moveToJointPosition", { joints: { lbr_iiwa_joint_1: 0.1 } }],
    ["NaN (not JSON)", "moveToJointPosition", '{"joints": {"lbr_iiwa_joint_1": NaN}}'],
    ["Infinity via 1e999", "moveToCartesianPosition", '{"x": 1e999, "y": 0, "z": 0.5}'],
    ["a missing body", "moveToCartesianPosition", ""],
    ["a string coordinate", "validateCartesianPosition", { x: "0.5", y: 0, z: 0.5 }],
    ["speed 0", "moveToJointPosition", { joints: HOME, speed: 0 }],
    ["speed 2", "moveToCartesianPosition", { x: 0.4, y: 0, z: 0.6, speed: 2 }],
    ["too few calibration pairs", "calibrate", { pairs: [{ real: { x: 0, y: 0, z: 0 }, virtual: { x: 0, y: 0, z: 0 } }] }],
    ["an obstacle with a negative size", "addObstacle", { name: "bad", shape: { type: "box", size: [0.1, -1, 0.1] }, position: [1, 1, 1] }],
    ["an obstacle without a name", "addObstacle", { shape: { type: "sphere", radius: 0.1 }, position: [1, 1, 1] }],
  ];
  it.each(cases)("%s", async (_what, action, body) => {
    const before = await readJoints();
    const statusBefore = await readStatus();
    const r = await invoke(base, action, body);
    expect(r.status).toBe(400);
    expect(r.type).toContain("application/problem+json");
    expect(typeof r.body.code).toBe("string");
    expect(typeof r.body.message).toBe("string");
    expect(r.body.details).toBeTypeOf("object");
    expect(await readJoints()).toEqual(before);
    expect(await readStatus()).toEqual(statusBefore);
  });

  it("collinear calibration pairs -> 400 naming the problem", async () => {
    const p = (t: number) => ({ real: { x: t, y: 2 * t, z: 0 }, virtual: { x: t, y: 2 * t, z: 0 } });
    const r = await invoke(base, "calibrate", { pairs: [p(0), p(1), p(2), p(3)] });
    expect(r.status).toBe(400);
    expect(r.body.message).toMatch(/collinear|degenerate/i);
    expect((await http(`${base}/properties/calibration`)).body).toEqual({ active: false });
  });
});

describe("motion control", () => {
  it("refuses a second move while moving (409) and stops mid-motion", async () => {
    await invoke(base, "moveToJointPosition", { joints: HOME });
    const long = invoke(base, "moveToJointPosition", { joints: kukaPose([2.5, 0, 0, 0, 0, 0, 0]), speed: 0.05 });
    await waitState(base, "moving");
    await waitMoved(base, "lbr_iiwa_joint_1", HOME.lbr_iiwa_joint_1 ?? 0);
    const busy = await invoke(base, "moveToJointPosition", { joints: BENT });
    expect(busy.status).toBe(409);
    expect(busy.body.code).toBe("E_BUSY");
    expect((await readStatus()).state).toBe("moving");
    const stop = await invoke(base, "stop", "");
    expect(stop.body).toEqual({ stopped: true, simulation: { ok: true } });
    const r = await long;
    expect(r.status).toBe(200);
    expect(r.body.status).toBe("stopped");
    expect(r.body.joints.lbr_iiwa_joint_1).toBeGreaterThan(0.01);
    expect(r.body.joints.lbr_iiwa_joint_1).toBeLessThan(2.4);
    const st = await readStatus();
    expect(st.state).toBe("stopped");
    expect((await readJoints()).lbr_iiwa_joint_1).toBeCloseTo(r.body.joints.lbr_iiwa_joint_1, 6);
  });

  it("moves around an obstacle across its straight path (a detour), and refuses (422) a target the obstacle touches", async () => {
    await invoke(base, "moveToJointPosition", { joints: HOME });
    const target = kukaPose([0, 0.9, 0, -0.6, 0, 0.5, 0]);
    const free = (await invoke(base, "validateJointPosition", { joints: target })).body;
    expect(free.valid).toBe(true);
    expect(free.checks.path.planned).toBe("straight");
    // a box across the arm's way between home and the target
    const add = await invoke(base, "addObstacle", { name: "wall", shape: { type: "box", size: [0.1, 0.6, 0.1] }, position: [0.45, 0, 0.9] });
    expect(add.status).toBe(200);
    const dup = await invoke(base, "addObstacle", { name: "wall", shape: { type: "sphere", radius: 0.05 }, position: [2, 2, 2] });
    expect(dup.status).toBe(409);
    const around = (await invoke(base, "validateJointPosition", { joints: target })).body;
    expect(around.valid).toBe(true);
    expect(around.checks.path.planned).toBe("detour");
    const moved = await invoke(base, "moveToJointPosition", { joints: target });
    expect(moved.status).toBe(200);
    expect(moved.body).toMatchObject({ status: "reached", path: "detour" });
    const tcp = (await http(`${base}/properties/getCartesianPosition`)).body;
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
    // now the target itself touches an obstacle: no path can help
    expect((await invoke(base, "moveObstacle", { name: "wall", position: [tcp.x, tcp.y, tcp.z] })).status).toBe(200);
    const before = await readJoints();
    const v = (await invoke(base, "validateJointPosition", { joints: target })).body;
    expect(v.valid).toBe(false);
    expect(v.checks.path.ok).toBe(false);
    const r = await invoke(base, "moveToJointPosition", { joints: target });
    expect(r.status).toBe(422);
    expect(r.body.code).toBe("E_REJECTED");
    expect(r.body.details.checks.path.ok).toBe(false);
    expect(await readJoints()).toEqual(before);
    expect((await invoke(base, "moveObstacle", { name: "wall", position: [-2, -2, 0.5] })).status).toBe(200);
    expect((await invoke(base, "validateJointPosition", { joints: target })).body.valid).toBe(true);
    expect((await invoke(base, "removeObstacle", { name: "wall" })).status).toBe(200);
    expect((await invoke(base, "removeObstacle", { name: "wall" })).status).toBe(404);
  });

  it("stops with a collision event when an obstacle appears in the path mid-motion", async () => {
    await invoke(base, "moveToJointPosition", { joints: HOME });
    const ws = await live(`${s.liveUrl}?thing=${slug}`);
    const c = await consumer();
    try {
      const thing = await c.wot.consume(await c.wot.requestThingDescription(base));
      const events: any[] = [];
      await thing.subscribeEvent("collision", async (d) => void events.push(await d.value()));
      const target = kukaPose([0, 1.2, 0, -0.4, 0, 0.4, 0]);
      const move = invoke(base, "moveToJointPosition", { joints: target, speed: 0.05 });
      // the obstacle comes into the path of the running motion
      await waitMoved(base, "lbr_iiwa_joint_2", 0);
      const add = await invoke(base, "addObstacle", { name: "intruder", shape: { type: "box", size: [0.2, 0.6, 0.2] }, position: [0.55, 0, 0.75] });
      expect(add.status).toBe(200);
      const r = await move;
      expect(r.status).toBe(200);
      expect(r.body.status).toBe("collision");
      const ev = await ws.waitFor((m) => m.type === "collision");
      expect(ev.pair.a.body === "intruder" || ev.pair.b.body === "intruder").toBe(true);
      expect(ev.depth).toBeGreaterThanOrEqual(0);
      expect(Object.keys(ev.joints)).toHaveLength(7);
      const st = await readStatus();
      expect(st.state).toBe("collision");
      expect(st.lastError.code).toBe("E_COLLISION");
      await waitFor(() => events.length > 0, { what: "the collision event over long poll" }).catch(() => undefined);
      expect(events[0]?.pair).toBeDefined();
    } finally {
      ws.close();
      await c.stop();
      await invoke(base, "removeObstacle", { name: "intruder" });
    }
  });
});
