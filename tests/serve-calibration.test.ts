/**
 * End to end: calibration (Kabsch-Umeyama through the `calibrate` action) recovers a known transform,
 * is persisted in calibration.json and applied to Cartesian inputs and outputs; relay to a second twin
 * standing in for the physical robot, placed with a known rotation and offset.
 */
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import type { Vec3 } from "../packages/core/src/index.js";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { apply, gauss, generateTwin, http, invoke, kukaPose, placeTwin, rng, rotZ, type Rigid } from "./serve-helpers.js";

type Xyz = { x: number; y: number; z: number };
function rotX(a: number): number[][] {
  return [
    [1, 0, 0],
    [0, Math.cos(a), -Math.sin(a)],
    [0, Math.sin(a), Math.cos(a)],
  ];
}
const mul = (A: number[][], B: number[][]): number[][] => A.map((r) => [0, 1, 2].map((j) => r[0]! * B[0]![j]! + r[1]! * B[1]![j]! + r[2]! * B[2]![j]!));
const xyz = (v: readonly number[]): Xyz => ({ x: v[0]!, y: v[1]!, z: v[2]! });
const dist = (a: Xyz, b: Xyz): number => Math.hypot(a.x - b.x, a.y - b.y, a.z - b.z);

let dir: string;
beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
});

describe("calibrate", () => {
  let s: RunningServient;
  let base: string;
  beforeAll(async () => {
    s = await startServient({ twins: [dir], port: 0, realtime: 0 });
    base = `${s.url}/${s.things[0]!.slug}`;
  });
  afterAll(async () => s?.stop());

  const T: Rigid = { s: 1.15, R: mul(rotZ(0.6), rotX(0.25)), t: [0.42, -0.31, 0.08] };
  const u = rng(7);
  const randomPoint = (): Vec3 => [u() * 1.2 - 0.6, u() * 1.2 - 0.6, u() * 1.0];

  it("recovers a known similarity transform from noise-free pairs (< 1e-6 m) and applies it", async () => {
    const virtual = Array.from({ length: 5 }, randomPoint);
    const pairs = virtual.map((v) => ({ virtual: xyz(v), real: xyz(apply(T, v)) }));
    const r = await invoke(base, "calibrate", { pairs, withScale: true });
    expect(r.status).toBe(200);
    expect(r.body.scale).toBeCloseTo(T.s, 9);
    expect(r.body.rms).toBeLessThan(1e-6);
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) expect(r.body.rotation[i][j]).toBeCloseTo(T.R[i]![j]!, 8);
    const est: Rigid = { s: r.body.scale, R: r.body.rotation, t: r.body.translation };
    for (let i = 0; i < 20; i++) {
      const v = randomPoint();
      const [e, g] = [apply(est, v), apply(T, v)];
      expect(Math.hypot(e[0] - g[0], e[1] - g[1], e[2] - g[2])).toBeLessThan(1e-6);
    }
    // persisted and reported
    const file = JSON.parse(readFileSync(join(dir, "calibration.json"), "utf8"));
    expect(file).toMatchObject({ scale: r.body.scale, pairs: 5, withScale: true });
    expect((await http(`${base}/properties/calibration`)).body.active).toBe(true);
    // outputs in the real frame: the reading equals T(virtual pose) within 1e-6 m
    const moved = await invoke(base, "moveToJointPosition", { joints: kukaPose([0.4, 0.5, 0, -1.0, 0, 0.6, 0]) });
    expect(moved.status).toBe(200);
    const real = (await http(`${base}/properties/getCartesianPosition`)).body as Xyz;
    // inputs in the real frame: a Cartesian move to that real point reaches it
    const back = await invoke(base, "moveToCartesianPosition", { ...real });
    expect(back.status).toBe(200);
    expect(back.body.positionError).toBeLessThan(1e-3);
    // the served TD's Cartesian bounds are in the real frame now
    const td = (await http(base)).body;
    const zIn = td.actions.moveToCartesianPosition.input.properties.z;
    expect(real.z).toBeGreaterThanOrEqual(zIn.minimum);
    expect(real.z).toBeLessThanOrEqual(zIn.maximum);
    // and the calibration survives a restart of the servient
    await s.stop();
    s = await startServient({ twins: [dir], port: 0, realtime: 0 });
    base = `${s.url}/${s.things[0]!.slug}`;
    const cal = (await http(`${base}/properties/calibration`)).body;
    expect(cal.active).toBe(true);
    expect(cal.scale).toBeCloseTo(T.s, 9);
    expect((await invoke(base, "moveToJointPosition", { joints: kukaPose([0.4, 0.5, 0, -1.0, 0, 0.6, 0]) })).status).toBe(200);
    const again = (await http(`${base}/properties/getCartesianPosition`)).body as Xyz;
    expect(dist(again, real)).toBeLessThan(1e-6);
  });

  it("predicts within 2 mm after calibrating from 10 pairs with 1 mm noise", async () => {
    const noisy = rng(11);
    const virtual = Array.from({ length: 10 }, randomPoint);
    const pairs = virtual.map((v) => {
      const p = apply(T, v);
      return { virtual: xyz(v), real: xyz(p.map((c) => c + 0.001 * gauss(noisy))) };
    });
    const r = await invoke(base, "calibrate", { pairs });
    expect(r.status).toBe(200);
    const est: Rigid = { s: r.body.scale, R: r.body.rotation, t: r.body.translation };
    let worst = 0;
    for (let i = 0; i < 50; i++) {
      const v = randomPoint();
      const e = apply(est, v);
      const g = apply(T, v);
      worst = Math.max(worst, Math.hypot(e[0] - g[0], e[1] - g[1], e[2] - g[2]));
    }
    expect(worst).toBeLessThanOrEqual(0.002);
    expect(r.body.rms).toBeGreaterThan(0);
    expect(r.body.rms).toBeLessThan(0.003);
  });
});

describe("relay to a second twin standing in for the physical robot", () => {
  let physical: RunningServient;
  let twin: RunningServient;
  let pBase: string;
  let vBase: string;
  const yaw = 0.7;
  const offset: Vec3 = [0.35, -0.25, 0.05];

  beforeAll(async () => {
    const pdir = await generateTwin("kuka_iiwa", 3000);
    placeTwin(pdir, yaw, offset);
    physical = await startServient({ twins: [pdir], port: 0, realtime: 0 });
    pBase = `${physical.url}/${physical.things[0]!.slug}`;
    const vdir = await generateTwin("kuka_iiwa", 3000);
    twin = await startServient({ twins: [vdir], port: 0, realtime: 0, relay: pBase });
    vBase = `${twin.url}/${twin.things[0]!.slug}`;
  });
  afterAll(async () => {
    await twin?.stop();
    await physical?.stop();
  });

  it("calibrates from 4 pairs and lands the physical end effector within 1 mm of a real-frame target", async () => {
    const configs = [
      [0.3, 0.5, 0, -1.0, 0, 0.6, 0],
      [-0.6, 0.7, 0.2, -0.8, 0, 0.4, 0],
      [1.0, 0.2, -0.3, -1.4, 0.2, 0.8, 0],
      [0.1, -0.4, 0, -1.6, 0, -0.5, 0],
    ];
    const pairs: { real: Xyz; virtual: Xyz }[] = [];
    for (const c of configs) {
      const r = await invoke(vBase, "moveToJointPosition", { joints: kukaPose(c) });
      expect(r.status).toBe(200);
      expect(r.body.relay.ok).toBe(true);
      const virtual = (await http(`${vBase}/properties/getCartesianPosition`)).body;
      const real = (await http(`${pBase}/properties/getCartesianPosition`)).body;
      pairs.push({ real: { x: real.x, y: real.y, z: real.z }, virtual: { x: virtual.x, y: virtual.y, z: virtual.z } });
    }
    const cal = await invoke(vBase, "calibrate", { pairs, withScale: false });
    expect(cal.status).toBe(200);
    expect(cal.body.rms).toBeLessThan(1e-4);
    expect(cal.body.translation[0]).toBeCloseTo(offset[0], 4);
    expect(cal.body.rotation[1][0]).toBeCloseTo(Math.sin(yaw), 4);

    const target = apply({ s: 1, R: rotZ(yaw), t: offset }, [0.45, 0.15, 0.55]);
    const r = await invoke(vBase, "moveToCartesianPosition", { ...xyz(target) });
    expect(r.status).toBe(200);
    expect(r.body.status).toBe("reached");
    expect(r.body.relay.ok).toBe(true);
    expect(dist(r.body.position, xyz(target))).toBeLessThan(0.001);
    const landed = (await http(`${pBase}/properties/getCartesianPosition`)).body;
    expect(dist(landed, xyz(target))).toBeLessThan(0.001);
  });

  it("reports a relay failure in the result and motionStatus instead of hiding it", async () => {
    await physical.stop();
    const r = await invoke(vBase, "moveToJointPosition", { joints: kukaPose([0.2, 0.3, 0, -0.9, 0, 0.5, 0]) });
    expect(r.status).toBe(200);
    expect(r.body.status).toBe("reached");
    expect(r.body.relay.ok).toBe(false);
    expect(typeof r.body.relay.error).toBe("string");
    const st = (await http(`${vBase}/properties/motionStatus`)).body;
    expect(st.lastError.code).toBe("E_RELAY");
  });
});
