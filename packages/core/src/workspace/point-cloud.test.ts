import { describe, expect, it } from "vitest";
import { ballPoints, rng } from "../test-support/shapes.js";
import { PointCloudIndex } from "./point-cloud.js";

/** 20,000 points in a ball of radius 1; configurations with x > 0.3 are labelled colliding. */
function fixture(): PointCloudIndex {
  const points = ballPoints(20000, 1, rng(11));
  const free = new Uint8Array(20000);
  for (let i = 0; i < 20000; i++) free[i] = points[3 * i]! > 0.3 ? 0 : 1;
  return new PointCloudIndex(points, free);
}

function bruteNearest(points: Float64Array, p: number[], k: number): number[] {
  const d = new Float64Array(points.length / 3);
  for (let i = 0; i < d.length; i++) d[i] = Math.hypot(points[3 * i]! - p[0]!, points[3 * i + 1]! - p[1]!, points[3 * i + 2]! - p[2]!);
  return Array.from(d.sort().subarray(0, k));
}

describe("PointCloudIndex", () => {
  const index = fixture();

  it("finds the same k nearest distances as brute force, inside and far outside the cloud", () => {
    const r = rng(5);
    for (let q = 0; q < 100; q++) {
      const scale = q < 80 ? 1.2 : 6;
      const p = [0, 1, 2].map(() => (2 * r() - 1) * scale);
      const got = index.nearest(p, 10).distance;
      const want = bruteNearest(index.points, p, 10);
      got.forEach((d, i) => expect(d).toBeCloseTo(want[i]!, 12));
    }
  });

  it.each([
    ["free region", [-0.5, 0, 0], 0, true],
    ["colliding region", [0.7, 0, 0], 1, false],
    ["far outside the cloud", [0, 0, 3], 0, false],
  ])("scores a target in the %s", (_label, p, share, ok) => {
    const s = index.score(p, 10);
    expect(s.k).toBe(10);
    expect(s.share).toBe(share);
    expect(s.colliding).toBe(share * 10);
    expect(index.check(p).ok).toBe(ok);
  });

  it("decides by the nearest collision-free sample, not by how many colliding samples are near", () => {
    // at the edge of the free region most neighbours collide, yet the position is reachable collision-free
    const edge = [0.33, 0, 0];
    const c = index.check(edge, { k: 40 });
    expect(c.share).toBeGreaterThan(0.5);
    expect(c.ok).toBe(true);
    expect(c.nearestFree).toBeLessThan(c.maxGap);
    // deep in the colliding region the nearest free sample is far: refused
    const deep = index.check([0.8, 0, 0]);
    expect(deep.nearestFree).toBeGreaterThan(0.4);
    expect(deep.ok).toBe(false);
    const outside = [-0.2, 0, 1.05];
    const near = index.check(outside).nearestFree;
    expect(index.check(outside, { maxGap: near * 0.99 }).ok).toBe(false);
    expect(index.check(outside, { maxGap: near }).ok).toBe(true);
    // the default gap is of the order of the point spacing (~ (volume / n)^(1/3) ≈ 0.06 m)
    expect(index.typicalSpacing()).toBeGreaterThan(0.02);
    expect(index.typicalSpacing()).toBeLessThan(0.12);
  });

  it("caps k at the number of points and validates input", () => {
    const tiny = new PointCloudIndex(Float64Array.from([0, 0, 0, 1, 0, 0]), Uint8Array.from([1, 0]));
    expect(tiny.score([0.2, 0, 0], 10)).toEqual({ k: 2, colliding: 1, share: 0.5, nearestDistance: 0.2 });
    expect(() => tiny.score([0, 0, NaN])).toThrow(/finite/);
    expect(() => tiny.score([0, 0, 0], 0)).toThrow(/k must be/);
    expect(tiny.check([0.9, 0, 0], { maxGap: 0.5 })).toMatchObject({ nearestFree: 0.9, ok: false });
    const none = new PointCloudIndex(Float64Array.from([0, 0, 0]), Uint8Array.from([0]));
    expect(none.check([0, 0, 0])).toMatchObject({ nearestFree: Infinity, ok: false });
    expect(() => new PointCloudIndex(new Float64Array(4), new Uint8Array(2))).toThrow(/3 × n/);
  });
});
