import { describe, expect, it } from "vitest";
import type { Vec3 } from "./types.js";
import { FrameMap } from "./calibration.js";
import { matToQuat, quatMul } from "./geometry.js";

type Mat3 = [Vec3, Vec3, Vec3];

const rot = (axis: [number, number, number], a: number): Mat3 => {
  const [x, y, z] = axis;
  const c = Math.cos(a);
  const s = Math.sin(a);
  const t = 1 - c;
  return [
    [t * x * x + c, t * x * y - s * z, t * x * z + s * y],
    [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
    [t * x * z - s * y, t * y * z + s * x, t * z * z + c],
  ];
};

describe("FrameMap", () => {
  const n = Math.SQRT1_2;
  const R = rot([n, 0, n], 0.9);
  const map = new FrameMap({ scale: 1.3, rotation: R, translation: [0.2, -0.4, 1.1] });

  it.each([
    [[0, 0, 0]],
    [[0.5, -0.2, 0.9]],
    [[-1, 2, -3]],
  ] as [number, number, number][][])("round-trips the point %j between frames", (p) => {
    const back = map.pointToVirtual(map.pointToReal(p));
    back.forEach((v, i) => expect(v).toBeCloseTo(p[i]!, 12));
  });

  it("maps x_real = s·R·x_virtual + t", () => {
    const r = map.pointToReal([1, 0, 0]);
    expect(r[0]).toBeCloseTo(1.3 * R[0][0] + 0.2, 12);
    expect(r[2]).toBeCloseTo(1.3 * R[2][0] + 1.1, 12);
  });

  it("rotates orientations by R and back", () => {
    const q = { x: 0.1, y: 0.2, z: 0.3, w: Math.sqrt(1 - 0.14) };
    const back = map.quatToVirtual(map.quatToReal(q));
    for (const k of ["x", "y", "z", "w"] as const) expect(back[k]).toBeCloseTo(q[k], 12);
  });

  it("matToQuat agrees with composing rotations", () => {
    const A = rot([0, 0, 1], 0.4);
    const B = rot([1, 0, 0], -1.2);
    const AB = A.map((r) => [0, 1, 2].map((j) => r[0]! * B[0]![j]! + r[1]! * B[1]![j]! + r[2]! * B[2]![j]!)) as Mat3;
    const q = quatMul(matToQuat(A), matToQuat(B));
    const p = matToQuat(AB);
    const sign = Math.sign(q.w * p.w + q.x * p.x + q.y * p.y + q.z * p.z);
    for (const k of ["x", "y", "z", "w"] as const) expect(sign * q[k]).toBeCloseTo(p[k], 12);
  });

  it("maps bounds to the axis-aligned box of the mapped corners; identity without calibration", () => {
    const b = { min: [-1, -1, 0] as [number, number, number], max: [1, 1, 1] as [number, number, number] };
    expect(new FrameMap(null).boundsToReal(b)).toBe(b);
    const out = new FrameMap({ scale: 1, rotation: rot([0, 0, 1], Math.PI / 4), translation: [1, 0, 0] }).boundsToReal(b);
    expect(out.max[0]).toBeCloseTo(1 + Math.SQRT2, 12);
    expect(out.min[2]).toBeCloseTo(0, 12);
  });
});
