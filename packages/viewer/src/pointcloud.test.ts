import { describe, expect, it } from "vitest";
import { RobwotError } from "@robwot/core/browser";
import { parseWorkspaceCsv } from "./pointcloud.js";

function csv(rows: number, extra = ""): string {
  const lines = [`x,y,z,collision_free${extra ? ",j1" : ""}`];
  for (let i = 0; i < rows; i++) lines.push(`${i * 0.001},${-i * 0.002},${0.5},${i % 4 === 0 ? 0 : 1}${extra}`);
  return `${lines.join("\n")}\n`;
}

describe("parseWorkspaceCsv", () => {
  it.each([
    ["with header", csv(10), 10],
    ["with joint columns", csv(10, ",0.25"), 10],
  ])("reads every point %s", (_label, text, n) => {
    const cloud = parseWorkspaceCsv(text);
    expect(cloud.total).toBe(n);
    expect(cloud.free.length).toBe(n);
    expect(cloud.collisionFree).toBe(7); // rows 0, 4, 8 collide
    expect(Array.from(cloud.positions.slice(3, 6))).toEqual([0.001, -0.002, 0.5].map(Math.fround));
  });

  it("subsamples a large cloud to the limit, keeping both classes in proportion", () => {
    const cloud = parseWorkspaceCsv(csv(10_000), 1_000);
    expect(cloud.total).toBe(10_000);
    expect(cloud.collisionFree).toBe(7_500);
    expect(cloud.free.length).toBeGreaterThan(900);
    expect(cloud.free.length).toBeLessThan(1_100);
    const freeShown = cloud.free.reduce((a, f) => a + f, 0);
    expect(freeShown / cloud.free.length).toBeCloseTo(0.75, 1);
  });

  it.each([
    ["a non-numeric coordinate", "x,y,z,collision_free\n0,0,0,1\n0,abc,0,1\n", 3],
    ["a label other than 0/1", "x,y,z,collision_free\n0,0,0,1\n0,0,0,1\n0,0,0,2\n", 4],
    ["a missing column", "x,y,z,collision_free\n0,0,0,1\n0,0\n", 3],
    ["an empty coordinate", "x,y,z,collision_free\n0,0,0,1\n0,,0,1\n", 3],
    ["a missing header", "0,0,0,1\n0,0,0,1\n", 1],
  ])("names the file and line of %s", (_label, text, line) => {
    let err: unknown;
    try {
      parseWorkspaceCsv(text, undefined, "twin/workspace.csv");
    } catch (e) {
      err = e;
    }
    expect(err).toBeInstanceOf(RobwotError);
    expect((err as RobwotError).code).toBe("E_BAD_CSV");
    expect((err as RobwotError).details).toMatchObject({ file: "twin/workspace.csv", line });
  });
});
