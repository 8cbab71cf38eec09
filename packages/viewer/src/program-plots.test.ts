import { describe, expect, it } from "vitest";
import { derivative, sampleTimes, speedOf, ticks } from "./program-plots.js";

describe("program plots' arithmetic", () => {
  it.each([
    ["a ramp", [0, 0.1, 0.2, 0.3], [0, 0.1, 0.2, 0.3], [1, 1, 1, 1]],
    ["a constant", [2, 2, 2], [0, 0.5, 1], [0, 0, 0]],
    ["one sample", [5], [0], [0]],
    ["a parabola (central inside, one-sided at the ends)", [0, 1, 4, 9], [0, 1, 2, 3], [1, 2, 4, 5]],
    ["a ramp whose last sample comes early", [0, 0.1, 0.15], [0, 0.1, 0.15], [1, 1, 1]],
  ])("derivative of %s", (_label, values, times, expected) => {
    derivative(values, times).forEach((v, i) => expect(v).toBeCloseTo(expected[i] ?? NaN, 12));
  });

  it.each([
    [4, 10, 0.3, [0, 0.1, 0.2, 0.3]],
    [4, 10, 0.25, [0, 0.1, 0.2, 0.25]],
    [1, 10, 0, [0]],
  ])("%i samples at %f Hz ending at %f s", (n, rate, end, expected) => {
    const times = sampleTimes(n, rate, end);
    expect(times).toHaveLength(expected.length);
    times.forEach((t, i) => expect(t).toBeCloseTo(expected[i] ?? NaN, 12));
  });

  it("the speed of points moving 0.3 m/s along (3, 4, 0) / 5 is 0.3 m/s", () => {
    const points = [0, 1, 2, 3].map((i): [number, number, number] => [0.018 * i, 0.024 * i, 0.5]);
    for (const v of speedOf(points, [0, 0.1, 0.2, 0.3])) expect(v).toBeCloseTo(0.3, 12);
  });

  it.each([
    [0, 0.65, [0, 0.2, 0.4, 0.6]],
    [-4, 4, [-4, -2, 0, 2, 4]],
    [-0.4, 0.5, [-0.4, -0.2, 0, 0.2, 0.4]],
  ])("ticks over [%f, %f]: round steps inside the range", (lo, hi, expected) => {
    ticks(lo, hi).forEach((v, i) => expect(v).toBeCloseTo(expected[i] ?? NaN, 12));
    expect(ticks(lo, hi)).toHaveLength(expected.length);
  });
});
