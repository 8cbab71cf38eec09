import { Matrix, determinant } from "ml-matrix";
import { describe, expect, it } from "vitest";
import { activeCalibration, applyCalibration, checkCalibration, invertCalibration, solveCalibration, type CalibrationPair } from "./calibration.js";
import { RobwotError } from "./errors.js";
import { gauss, rng } from "./test-support/shapes.js";
import type { Vec3 } from "./types.js";

/** Random proper rotation from a random unit quaternion. */
function randomRotation(r: () => number): number[][] {
  const q = [gauss(r), gauss(r), gauss(r), gauss(r)];
  const l = Math.hypot(...q);
  const [x, y, z, w] = q.map((v) => v / l) as [number, number, number, number];
  return [
    [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
    [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
    [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
  ];
}

const randomPoint = (r: () => number, half = 0.8): Vec3 => [0, 1, 2].map(() => (2 * r() - 1) * half) as Vec3;

function truth(seed: number, withScale = true): { scale: number; rotation: number[][]; translation: Vec3 } {
  const r = rng(seed);
  return { scale: withScale ? 0.5 + r() : 1, rotation: randomRotation(r), translation: randomPoint(r, 2) };
}

function expectOrthonormal(R: number[][]): void {
  const m = new Matrix(R);
  const I = m.mmul(m.transpose());
  for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) expect(I.get(i, j)).toBeCloseTo(i === j ? 1 : 0, 12);
  expect(determinant(m)).toBeCloseTo(1, 12);
}

describe("solveCalibration", () => {
  it.each([1, 2, 3, 4, 5])("recovers a noise-free random similarity transform exactly (seed %i)", (seed) => {
    const t = truth(seed);
    const r = rng(100 + seed);
    const pairs = Array.from({ length: 6 }, () => {
      const v = randomPoint(r);
      return { virtual: v, real: applyCalibration(t, v) };
    });
    const cal = solveCalibration(pairs);
    expect(Math.abs(cal.scale - t.scale)).toBeLessThan(1e-9);
    for (let i = 0; i < 3; i++) {
      expect(Math.abs(cal.translation[i]! - t.translation[i]!)).toBeLessThan(1e-9);
      for (let j = 0; j < 3; j++) expect(Math.abs(cal.rotation[i]![j]! - t.rotation[i]![j]!)).toBeLessThan(1e-9);
    }
    expect(cal.rms).toBeLessThan(1e-9);
    expect(cal.pairs).toBe(6);
    expectOrthonormal(cal.rotation);
  });

  it("accepts {x, y, z} objects and solves without scale (Kabsch)", () => {
    const t = truth(9, false);
    const r = rng(9);
    const pairs = Array.from({ length: 4 }, () => {
      const v = randomPoint(r);
      const w = applyCalibration(t, v);
      return { virtual: { x: v[0], y: v[1], z: v[2] }, real: { x: w[0], y: w[1], z: w[2] } };
    });
    const cal = solveCalibration(pairs, { withScale: false });
    expect(cal.scale).toBe(1);
    expect(cal.withScale).toBe(false);
    expect(cal.rms).toBeLessThan(1e-9);
  });

  it("predicts held-out points within 2 mm (RMS per trial) from 10 pairs with σ = 1 mm noise", () => {
    const r = rng(42);
    for (let trial = 0; trial < 10; trial++) {
      const t = truth(200 + trial);
      const pairs: CalibrationPair[] = Array.from({ length: 10 }, () => {
        const v = randomPoint(r);
        const w = applyCalibration(t, v);
        return { virtual: v, real: w.map((c) => c + 0.001 * gauss(r)) as Vec3 };
      });
      const cal = solveCalibration(pairs);
      expect(cal.rms).toBeGreaterThan(0.0003);
      expect(cal.rms).toBeLessThan(0.003);
      let sq = 0;
      let worst = 0;
      for (let i = 0; i < 200; i++) {
        const v = randomPoint(r);
        const a = applyCalibration(cal, v);
        const b = applyCalibration(t, v);
        const e = Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
        sq += e * e;
        worst = Math.max(worst, e);
      }
      expect(Math.sqrt(sq / 200)).toBeLessThanOrEqual(0.002);
      expect(worst).toBeLessThanOrEqual(0.004);
    }
  });

  it("returns a proper rotation for 3 coplanar pairs whatever the SVD's sign choices", () => {
    for (let seed = 0; seed < 40; seed++) {
      const t = truth(300 + seed);
      const r = rng(seed);
      const pairs = Array.from({ length: 3 }, () => {
        const v = randomPoint(r);
        return { virtual: v, real: applyCalibration(t, v) };
      });
      const cal = solveCalibration(pairs);
      expectOrthonormal(cal.rotation);
      expect(cal.rms).toBeLessThan(1e-9);
    }
  });

  it("never returns a reflection: mirrored data fit no proper rotation and are refused", () => {
    const r = rng(77);
    const pairs = Array.from({ length: 8 }, () => {
      const v = randomPoint(r);
      return { virtual: v, real: [-v[0], v[1], v[2]] as Vec3 };
    });
    expect(() => solveCalibration(pairs)).toThrow(/RMS residual|scale/);
  });

  it("checkCalibration accepts a solved calibration and refuses absurd stored ones", () => {
    const t = truth(5);
    expect(() => checkCalibration(t)).not.toThrow();
    expect(() => checkCalibration({ ...t, scale: Infinity })).toThrow(/scale/);
    expect(() => checkCalibration({ ...t, rotation: [[1, 0, 0], [0, 1, 0], [0, 0, -1]] })).toThrow(/not a rotation/);
    expect(() => checkCalibration({ ...t, translation: [0, 0, 1e9] })).toThrow(/translation/);
  });

  it("inverts: invertCalibration(applyCalibration(p)) = p", () => {
    const t = truth(5);
    const r = rng(5);
    for (let i = 0; i < 20; i++) {
      const p = randomPoint(r);
      const q = invertCalibration(t, applyCalibration(t, p));
      p.forEach((c, k) => expect(q[k]).toBeCloseTo(c, 12));
    }
  });

  const P = (v: Vec3, w: Vec3 = v): CalibrationPair => ({ virtual: v, real: w });
  it.each([
    ["fewer than 3 pairs", [P([0, 0, 0]), P([1, 0, 0])], /at least 3 point pairs, got 2/, "too-few-pairs"],
    ["collinear virtual points", [P([0, 0, 0], [0, 0, 0]), P([1, 1, 1], [0, 1, 0]), P([2, 2, 2], [1, 0, 0]), P([3, 3, 3], [0, 0, 1])], /virtual points are collinear/, "collinear"],
    ["collinear real points", [P([0, 0, 0], [0, 0, 0]), P([1, 0, 0], [1, 0, 0]), P([0, 1, 0], [2, 0, 0])], /real points are collinear/, "collinear"],
    ["coincident points", [P([1, 2, 3]), P([1, 2, 3]), P([1, 2, 3])], /virtual points coincide/, "coincident"],
  ])("rejects %s with E_CALIBRATION and a reason", (_label, pairs, message, reason) => {
    expect(() => solveCalibration(pairs)).toThrow(message);
    try {
      solveCalibration(pairs);
    } catch (e) {
      expect(e).toBeInstanceOf(RobwotError);
      expect((e as RobwotError).code).toBe("E_CALIBRATION");
      expect((e as RobwotError).details.reason).toBe(reason);
    }
  });

  it.each([
    ["NaN", NaN],
    ["Infinity", Infinity],
  ])("rejects %s naming the pair", (_label, bad) => {
    const pairs = [P([0, 0, 0]), P([1, 0, 0]), { virtual: [0, 1, 0] as Vec3, real: [0, bad, 0] as Vec3 }];
    expect(() => solveCalibration(pairs)).toThrow(/pairs\[2\]\.real must be 3 finite numbers/);
  });

  it("rejects malformed pairs from JSON", () => {
    const pairs = JSON.parse('[{"real":[0,0,0],"virtual":[0,0,0]},{"real":[1,0,0]},{"real":[0,1,0],"virtual":[0,1]}]') as CalibrationPair[];
    expect(() => solveCalibration(pairs)).toThrow(/pairs\[1\]\.virtual/);
  });
});

describe("activeCalibration (a twin's calibration property)", () => {
  const yaw = 0.7;
  const active = {
    active: true,
    scale: 1.25,
    rotation: [
      [Math.cos(yaw), -Math.sin(yaw), 0],
      [Math.sin(yaw), Math.cos(yaw), 0],
      [0, 0, 1],
    ],
    translation: [0.3, -0.2, 0.1],
    rms: 0,
    pairs: 4,
  };

  it("gives the transform of an active calibration; a real-frame point maps back to the virtual frame", () => {
    const c = activeCalibration(active);
    expect(c).not.toBeNull();
    const v: [number, number, number] = [0.4, 0.1, 0.6];
    const back = invertCalibration(c!, applyCalibration(c!, v));
    back.forEach((b, i) => expect(b).toBeCloseTo(v[i]!, 12));
  });

  it.each([
    ["inactive", { active: false }],
    ["not an object", "calibrated"],
    ["null", null],
  ])("is null when %s", (_label, value) => {
    expect(activeCalibration(value)).toBeNull();
  });

  it.each([
    ["missing rotation", { ...active, rotation: undefined }, /rotation/],
    ["zero scale", { ...active, scale: 0 }, /scale/],
    ["short translation", { ...active, translation: [1, 2] }, /translation/],
  ])("refuses an active one with %s, naming the field", (_label, value, field) => {
    expect(() => activeCalibration(value)).toThrow(field);
  });
});
