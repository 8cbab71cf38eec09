import { describe, expect, it } from "vitest";
import { reachOverlaps, startCollision } from "./overlap.js";

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

describe("startCollision", () => {
  const contact = (link: string, body: string, depth: number) => ({ a: { body: "arm", link }, b: { body, link: null }, depth, position: [0, 0, 0] as [number, number, number] });

  it("names the pairs deepest first, counts those past four, and says nothing of a free pose", () => {
    expect(startCollision("the start pose", [])).toBeUndefined();
    const two = startCollision("the start pose (--home)", [contact("link_2", "table", 0.004), contact("link_3", "table", 0.022)]);
    expect(two).toMatch(/^the start pose \(--home\) collides \(arm\/link_3 with table \(22\.0 mm deep\), arm\/link_2 with table \(4\.0 mm deep\)\): a move must first leave the contact/);
    const six = startCollision("twin arm: its start pose", Array.from({ length: 6 }, (_, i) => contact(`link_${i}`, "box", 0.001 * (i + 1))));
    expect(six).toMatch(/\(arm\/link_5 with box \(6\.0 mm deep\), .*arm\/link_2 with box \(3\.0 mm deep\) and 2 more pair\(s\)\)/);
  });
});
