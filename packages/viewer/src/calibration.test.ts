import { describe, expect, it } from "vitest";
import { parseCalibration, realToVirtual } from "./calibration.js";

describe("calibration in the viewer", () => {
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

  it("maps a real-frame point back to the virtual frame (inverse of s·R·x + t)", () => {
    const c = parseCalibration(active);
    expect(c).not.toBeNull();
    const v = [0.4, 0.1, 0.6];
    const real = [0, 1, 2].map((i) => active.scale * active.rotation[i]!.reduce((a, r, j) => a + r * v[j]!, 0) + active.translation[i]!);
    const back = realToVirtual(c!, { x: real[0]!, y: real[1]!, z: real[2]! });
    back.forEach((b, i) => expect(b).toBeCloseTo(v[i]!, 12));
  });

  it.each([
    ["inactive", { active: false }],
    ["missing rotation", { ...active, rotation: undefined }],
    ["zero scale", { ...active, scale: 0 }],
    ["short translation", { ...active, translation: [1, 2] }],
    ["not an object", "calibrated"],
  ])("is null when %s", (_label, value) => {
    expect(parseCalibration(value)).toBeNull();
  });
});
