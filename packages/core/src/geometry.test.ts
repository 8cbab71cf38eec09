import { describe, expect, it } from "vitest";
import { axisAngle, spreadOffLine } from "./geometry.js";

const yaw = (a: number): number[][] => [
  [Math.cos(a), -Math.sin(a), 0],
  [Math.sin(a), Math.cos(a), 0],
  [0, 0, 1],
];

describe("geometry", () => {
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
