/** Unsigned distance from a point to a triangle mesh, accelerated by a uniform 3D grid. Pure. */
import { Grid3, type Dims } from "./grid3.js";

/** Squared distance from p to triangle (a, b, c) (Ericson, Real-Time Collision Detection 5.1.5). */
export function pointTriangleDistanceSq(p: readonly number[], t: Float64Array, o: number): number {
  const ax = t[o]!, ay = t[o + 1]!, az = t[o + 2]!;
  const abx = t[o + 3]! - ax, aby = t[o + 4]! - ay, abz = t[o + 5]! - az;
  const acx = t[o + 6]! - ax, acy = t[o + 7]! - ay, acz = t[o + 8]! - az;
  const apx = p[0]! - ax, apy = p[1]! - ay, apz = p[2]! - az;
  const d1 = abx * apx + aby * apy + abz * apz;
  const d2 = acx * apx + acy * apy + acz * apz;
  const sq = (x: number, y: number, z: number): number => x * x + y * y + z * z;
  if (d1 <= 0 && d2 <= 0) return sq(apx, apy, apz);
  const bpx = apx - abx, bpy = apy - aby, bpz = apz - abz;
  const d3 = abx * bpx + aby * bpy + abz * bpz;
  const d4 = acx * bpx + acy * bpy + acz * bpz;
  if (d3 >= 0 && d4 <= d3) return sq(bpx, bpy, bpz);
  const vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const v = d1 / (d1 - d3);
    return sq(apx - v * abx, apy - v * aby, apz - v * abz);
  }
  const cpx = apx - acx, cpy = apy - acy, cpz = apz - acz;
  const d5 = abx * cpx + aby * cpy + abz * cpz;
  const d6 = acx * cpx + acy * cpy + acz * cpz;
  if (d6 >= 0 && d5 <= d6) return sq(cpx, cpy, cpz);
  const vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const w = d2 / (d2 - d6);
    return sq(apx - w * acx, apy - w * acy, apz - w * acz);
  }
  const va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
    const w = (d4 - d3) / (d4 - d3 + (d5 - d6));
    const bcx = acx - abx, bcy = acy - aby, bcz = acz - abz;
    return sq(bpx - w * bcx, bpy - w * bcy, bpz - w * bcz);
  }
  const denom = 1 / (va + vb + vc);
  const v = vb * denom, w = vc * denom;
  return sq(apx - abx * v - acx * w, apy - aby * v - acy * w, apz - abz * v - acz * w);
}

export class SurfaceDistanceGrid {
  private readonly grid: Grid3;
  private readonly items: Int32Array;
  private readonly stamp: Int32Array;
  private query = 0;

  constructor(private readonly tri: Float64Array, min: readonly number[], max: readonly number[]) {
    const count = tri.length / 9;
    const ext = [0, 1, 2].map((k) => Math.max(max[k]! - min[k]!, 1e-9));
    const size = Math.max(Math.cbrt((ext[0]! * ext[1]! * ext[2]!) / Math.max(count, 1)), Math.max(...ext) / 256);
    const n = [0, 1, 2].map((k) => Math.floor(ext[k]! / size) + 1) as Dims;
    const cellOf = (x: number, k: number): number => Math.min(n[k]! - 1, Math.max(0, Math.floor((x - min[k]!) / size)));
    const cells = n[0] * n[1] * n[2];
    const each = (t: number, f: (c: number) => void): void => {
      const o = 9 * t;
      const lo = [0, 1, 2].map((k) => cellOf(Math.min(tri[o + k]!, tri[o + 3 + k]!, tri[o + 6 + k]!), k));
      const hi = [0, 1, 2].map((k) => cellOf(Math.max(tri[o + k]!, tri[o + 3 + k]!, tri[o + 6 + k]!), k));
      for (let i = lo[0]!; i <= hi[0]!; i++) for (let j = lo[1]!; j <= hi[1]!; j++) for (let l = lo[2]!; l <= hi[2]!; l++) f((i * n[1] + j) * n[2] + l);
    };
    const start = new Int32Array(cells + 1);
    for (let t = 0; t < count; t++) each(t, (c) => start[c + 1]!++);
    for (let c = 0; c < cells; c++) start[c + 1]! += start[c]!;
    this.items = new Int32Array(start[cells]!);
    const fill = start.slice(0, cells);
    for (let t = 0; t < count; t++) each(t, (c) => (this.items[fill[c]!++] = t));
    this.stamp = new Int32Array(count);
    this.grid = new Grid3(min, size, n, start);
  }

  /** Distance (m) from p to the nearest triangle; Infinity for an empty mesh. */
  distance(p: readonly number[]): number {
    const q = ++this.query;
    const { start } = this.grid;
    let best = Infinity;
    this.grid.search(
      p,
      (cell) => {
        for (let k = start[cell]!; k < start[cell + 1]!; k++) {
          const t = this.items[k]!;
          if (this.stamp[t] === q) continue;
          this.stamp[t] = q;
          best = Math.min(best, pointTriangleDistanceSq(p, this.tri, 9 * t));
        }
      },
      (radius) => radius !== Infinity && !(Math.sqrt(best) <= radius),
    );
    return Math.sqrt(best);
  }
}
