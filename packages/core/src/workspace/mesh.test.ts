import { describe, expect, it } from "vitest";
import { box, concat, flip, icosphere, rng } from "../test-support/shapes.js";
import { WorkspaceMesh } from "./mesh.js";
import { RayGrid } from "./ray-grid.js";
import { writeStl } from "./stl.js";
import { pointTriangleDistanceSq } from "./surface-distance.js";

/** Distance from the centre to the flat face of an icosphere's triangles (inscribed radius). */
function inscribedRadius(tri: Float64Array): number {
  let r = Infinity;
  for (let o = 0; o < tri.length; o += 9) {
    const n = [0, 1, 2].map((k) => (tri[o + k]! + tri[o + 3 + k]! + tri[o + 6 + k]!) / 3);
    r = Math.min(r, Math.hypot(n[0]!, n[1]!, n[2]!));
  }
  return r;
}

describe("WorkspaceMesh", () => {
  const sphereTri = icosphere(4, 1);
  const sphere = WorkspaceMesh.fromStl(writeStl(sphereTri));
  const rIn = inscribedRadius(sphereTri);

  it("classifies random points against a sphere (away from the faceted boundary)", () => {
    const r = rng(7);
    let checked = 0;
    for (let i = 0; i < 5000; i++) {
      const p = [0, 1, 2].map(() => (2 * r() - 1) * 1.3);
      const d = Math.hypot(p[0]!, p[1]!, p[2]!);
      if (d > rIn - 1e-3 && d < 1 + 1e-3) continue; // between the facets and the true sphere
      expect(sphere.contains(p), `p=${p} |p|=${d}`).toBe(d < rIn);
      checked++;
    }
    expect(checked).toBeGreaterThan(4000);
  });

  it("handles a non-convex shell: the cavity is outside", () => {
    const shellTri = concat(icosphere(3, 1), flip(icosphere(3, 0.5)));
    const shell = new WorkspaceMesh(shellTri);
    expect(shell.contains([0, 0, 0])).toBe(false);
    expect(shell.contains([0.1, 0.2, -0.1])).toBe(false);
    expect(shell.contains([0.75, 0, 0])).toBe(true);
    expect(shell.contains([0, -0.4, 0.6])).toBe(true);
    expect(shell.contains([0, 0, 1.2])).toBe(false);
    expect(shell.isClosed()).toBe(true);
    expect(shell.isOutwardOriented()).toBe(true);
    expect(shell.volume()).toBeCloseTo((4 / 3) * Math.PI * (1 - 0.125), 1);
  });

  it("counts rays through shared edges and vertices once (axis-aligned grid points in a box)", () => {
    const cubeTri = concat(box([-1, -1, -1], [1, 1, 1]), box([2, -1, -1], [4, 1, 1]));
    const cube = new WorkspaceMesh(cubeTri);
    const grids = ([0, 1, 2] as const).map((a) => new RayGrid(cubeTri, a, cube.bounds.min, cube.bounds.max));
    const coords = [-1.5, -1, -0.5, 0, 0.5, 1, 1.5];
    for (const x of [...coords, 2.5, 3, 3.5]) {
      for (const y of coords) {
        for (const z of coords) {
          const inA = Math.abs(x) < 1 && Math.abs(y) < 1 && Math.abs(z) < 1;
          const inB = x > 2 && x < 4 && Math.abs(y) < 1 && Math.abs(z) < 1;
          const onBoundary = [x, y, z].some((v) => Math.abs(v) === 1) || x === 2 || x === 4;
          if (onBoundary) continue;
          expect(cube.contains([x, y, z]), `(${x}, ${y}, ${z})`).toBe(inA || inB);
          // each axis alone already gets the parity right (no reliance on the vote)
          for (const g of grids) expect(g.crossings([x, y, z]) & 1, `(${x}, ${y}, ${z})`).toBe(inA || inB ? 1 : 0);
        }
      }
    }
  });

  it("reports closedness and orientation", () => {
    expect(sphere.isClosed()).toBe(true);
    expect(sphere.isOutwardOriented()).toBe(true);
    expect(sphere.volume()).toBeGreaterThan(4);
    const open = new WorkspaceMesh(sphereTri.subarray(0, sphereTri.length - 9));
    expect(open.isClosed()).toBe(false);
    expect(open.topology().boundaryEdges).toBe(3);
    const inward = new WorkspaceMesh(flip(sphereTri));
    expect(inward.isClosed()).toBe(true);
    expect(inward.isOutwardOriented()).toBe(false);
    expect(inward.contains([0, 0, 0])).toBe(true);
    const mixed = sphereTri.slice();
    mixed.set(flip(sphereTri.subarray(0, 9)), 0);
    expect(new WorkspaceMesh(mixed).topology().misorientedEdges).toBe(3);
  });

  it("measures the distance to the surface like brute force", () => {
    const mesh = new WorkspaceMesh(icosphere(2, 1, [0.5, 0, 0]));
    const r = rng(3);
    for (let i = 0; i < 200; i++) {
      const p = [0, 1, 2].map(() => (2 * r() - 1) * 3);
      let brute = Infinity;
      for (let t = 0; t < mesh.triangleCount; t++) brute = Math.min(brute, pointTriangleDistanceSq(p, mesh.triangles, 9 * t));
      brute = Math.sqrt(brute);
      expect(mesh.distanceToSurface(p)).toBeCloseTo(brute, 12);
    }
    expect(mesh.signedDistance([0.5, 0, 0])).toBeLessThan(-0.9);
    expect(mesh.distanceToSurface([0.5, 0, 1])).toBeLessThan(1e-12);
  });

  it("rejects non-finite points and empty meshes", () => {
    expect(() => sphere.contains([0, NaN, 0])).toThrow(/finite/);
    expect(() => sphere.contains([0, 0])).toThrow(/finite/);
    expect(() => new WorkspaceMesh(new Float64Array(0))).toThrow(/at least one triangle/);
  });
});
