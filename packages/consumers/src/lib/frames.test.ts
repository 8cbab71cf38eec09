import { describe, expect, it } from "vitest";
import { applySimilarity, axisAngle, invertSimilarity, spreadOffLine, type V3 } from "./frames.js";

const yaw = (a: number): number[][] => [
  [Math.cos(a), -Math.sin(a), 0],
  [Math.sin(a), Math.cos(a), 0],
  [0, 0, 1],
];

describe("frames", () => {
  it.each([
    [1, 0.4, [0.3, -0.2, 0.05]],
    [1.7, -2.1, [0, 0, 0]],
    [0.5, Math.PI / 2, [-1, 2, 3]],
  ])("invertSimilarity undoes applySimilarity (s=%d, yaw=%d)", (scale, angle, t) => {
    const c = { scale, rotation: yaw(angle), translation: t };
    const x: V3 = [0.12, -0.7, 1.3];
    const back = invertSimilarity(c, applySimilarity(c, x));
    back.forEach((v, i) => expect(v).toBeCloseTo(x[i] as number, 12));
  });

  it("axisAngle recovers a yaw", () => {
    const { angle, axis } = axisAngle(yaw(0.436));
    expect(angle).toBeCloseTo(0.436, 12);
    expect(axis[2]).toBeCloseTo(1, 12);
  });

  it("spreadOffLine is 0 for collinear points and the offset otherwise", () => {
    expect(spreadOffLine([[0, 0, 0], [1, 1, 1], [2, 2, 2]])).toBeCloseTo(0, 12);
    expect(spreadOffLine([[0, 0, 0], [2, 0, 0], [1, 0.5, 0]])).toBeCloseTo(0.5, 12);
  });
});
