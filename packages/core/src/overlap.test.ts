import { describe, expect, it } from "vitest";
import { reachOverlaps } from "./overlap.js";

const box = (c: [number, number, number], r: number) => ({ min: c.map((v) => v - r) as [number, number, number], max: c.map((v) => v + r) as [number, number, number] });

describe("reachOverlaps", () => {
  it("says when robots stand at the same place, within one another's reach, or share space; nothing when apart", () => {
    const a = { name: "a", base: [0, 0, 0] as [number, number, number], reach: box([0, 0, 0.5], 1) };
    expect(reachOverlaps([a, { name: "b", base: [0.01, 0, 0], reach: box([0, 0, 0.5], 1) }])[0]).toMatch(/^a and b stand at the same place/);
    expect(reachOverlaps([a, { name: "c", base: [0.8, 0, 0] }])[0]).toMatch(/^c stands within a's reach \(0\.800 m apart\)/);
    expect(reachOverlaps([a, { name: "d", base: [1.8, 0, 0], reach: box([1.8, 0, 0.5], 1) }])[0]).toMatch(/^a and d can reach into the same space/);
    expect(reachOverlaps([a, { name: "e", base: [5, 0, 0], reach: box([5, 0, 0.5], 1) }])).toEqual([]);
    expect(reachOverlaps([a, { name: "f", base: [5, 0, 0] }])).toEqual([]);
  });
});
