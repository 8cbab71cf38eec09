/**
 * Nearest-neighbour checks against the labelled workspace point cloud (`workspace.csv`). Uniform 3D grid,
 * exact kNN. Pure.
 *
 * Rule of `check`: a position is reachable collision-free when a collision-free sample lies near it:
 * ok = nearestFree <= maxGap, where nearestFree is the distance to the nearest collision-free sample and
 * maxGap defaults to 2 × the 95th percentile of the nearest-neighbour spacing of (a deterministic sample
 * of up to 2,000) collision-free samples. The original's measure — the share of colliding samples among
 * the k nearest (`share`) — is still reported, but it counts how many colliding configurations (often
 * self-colliding ones of other arm postures) end near the position, not whether the position can be
 * reached without collision, so it does not decide.
 */
import { InvalidArgumentError } from "../errors.js";
import { Grid3, type Dims } from "./grid3.js";

export interface PointCloudScore {
  /** neighbours used (min(k, number of points)) */
  k: number;
  /** neighbours whose configuration was colliding */
  colliding: number;
  /** colliding / k, in [0, 1] */
  share: number;
  /** distance (m) to the nearest point */
  nearestDistance: number;
}

export interface PointCloudCheck extends PointCloudScore {
  ok: boolean;
  /** distance (m) to the nearest collision-free sample (Infinity when there is none) */
  nearestFree: number;
  maxGap: number;
}

export class PointCloudIndex {
  readonly size: number;
  private readonly grid: Grid3;
  private readonly order: Int32Array;
  private spacing: number | undefined;
  private freeIndex: PointCloudIndex | null | undefined;

  constructor(readonly points: Float64Array, readonly collisionFree: Uint8Array) {
    const size = collisionFree.length;
    if (points.length !== 3 * size || size === 0) {
      throw new InvalidArgumentError(`point cloud needs 3 × n coordinates for n >= 1 labels (got ${points.length} coordinates, ${size} labels)`, {
        param: "points",
        got: points.length,
        expected: 3 * size,
      });
    }
    this.size = size;
    const min = [Infinity, Infinity, Infinity];
    const max = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < size; i++) {
      for (let k = 0; k < 3; k++) {
        const v = points[3 * i + k]!;
        if (!Number.isFinite(v)) throw new InvalidArgumentError(`point ${i} has a non-finite coordinate`, { param: "points", index: i });
        if (v < min[k]!) min[k] = v;
        if (v > max[k]!) max[k] = v;
      }
    }
    const ext = [0, 1, 2].map((k) => Math.max(max[k]! - min[k]!, 1e-9));
    // about 4 points per cell on average, at most 128 cells per axis
    const cell = Math.max(Math.cbrt((ext[0]! * ext[1]! * ext[2]! * 4) / size), Math.max(...ext) / 128);
    const n = [0, 1, 2].map((k) => Math.floor(ext[k]! / cell) + 1) as Dims;
    const cells = n[0] * n[1] * n[2];
    const cellOf = new Int32Array(size);
    const start = new Int32Array(cells + 1);
    for (let i = 0; i < size; i++) {
      let c = 0;
      for (let k = 0; k < 3; k++) c = c * n[k]! + Math.min(n[k]! - 1, Math.floor((points[3 * i + k]! - min[k]!) / cell));
      cellOf[i] = c;
      start[c + 1]!++;
    }
    for (let c = 0; c < cells; c++) start[c + 1]! += start[c]!;
    this.order = new Int32Array(size);
    const fill = start.slice(0, cells);
    for (let i = 0; i < size; i++) this.order[fill[cellOf[i]!]!++] = i;
    this.grid = new Grid3(min, cell, n, start);
  }

  /** Indices and distances of the k nearest points, nearest first. `skip` excludes one index. */
  nearest(p: readonly number[], k: number, skip = -1): { index: number[]; distance: number[] } {
    const x = p[0], y = p[1], z = p[2];
    if (x === undefined || y === undefined || z === undefined || ![x, y, z].every(Number.isFinite)) {
      throw new InvalidArgumentError(`point must be 3 finite numbers, got ${JSON.stringify(p)}`, { param: "p", got: p });
    }
    if (!Number.isInteger(k) || k < 1) throw new InvalidArgumentError(`k must be an integer >= 1, got ${k}`, { param: "k", got: k });
    const want = Math.min(k, this.size - (skip >= 0 ? 1 : 0));
    const idx = new Int32Array(want);
    const d2 = new Float64Array(want).fill(Infinity);
    let found = 0;
    const { start } = this.grid;
    const pts = this.points;
    this.grid.search(
      p,
      (cell) => {
        for (let m = start[cell]!; m < start[cell + 1]!; m++) {
          const i = this.order[m]!;
          if (i === skip) continue;
          const dx = pts[3 * i]! - x, dy = pts[3 * i + 1]! - y, dz = pts[3 * i + 2]! - z;
          const d = dx * dx + dy * dy + dz * dz;
          if (found === want && d >= d2[want - 1]!) continue;
          let pos = found < want ? found++ : want - 1;
          while (pos > 0 && d2[pos - 1]! > d) {
            d2[pos] = d2[pos - 1]!;
            idx[pos] = idx[pos - 1]!;
            pos--;
          }
          d2[pos] = d;
          idx[pos] = i;
        }
      },
      (radius) => radius !== Infinity && !(found === want && Math.sqrt(d2[want - 1]!) <= radius),
    );
    return { index: Array.from(idx.subarray(0, found)), distance: Array.from(d2.subarray(0, found), Math.sqrt) };
  }

  score(p: readonly number[], k = 10): PointCloudScore {
    const { index, distance } = this.nearest(p, k);
    let colliding = 0;
    for (const i of index) if (this.collisionFree[i] === 0) colliding++;
    return { k: index.length, colliding, share: index.length > 0 ? colliding / index.length : 1, nearestDistance: distance[0] ?? Infinity };
  }

  /** 95th percentile of nearest-neighbour distances over a deterministic sample of points (m). */
  typicalSpacing(): number {
    if (this.spacing === undefined) {
      const m = Math.min(this.size, 2000);
      const step = this.size / m;
      const ds: number[] = [];
      for (let s = 0; s < m; s++) {
        const i = Math.floor(s * step);
        const d = this.nearest([this.points[3 * i]!, this.points[3 * i + 1]!, this.points[3 * i + 2]!], 1, i).distance[0];
        if (d !== undefined) ds.push(d);
      }
      ds.sort((a, b) => a - b);
      this.spacing = ds.length > 0 ? ds[Math.min(ds.length - 1, Math.floor(0.95 * ds.length))]! : 0;
    }
    return this.spacing;
  }

  /** The collision-free samples alone (null when there are none). */
  free(): PointCloudIndex | null {
    if (this.freeIndex === undefined) {
      const keep: number[] = [];
      for (let i = 0; i < this.size; i++) if (this.collisionFree[i] === 1) keep.push(i);
      const pts = new Float64Array(3 * keep.length);
      keep.forEach((i, j) => pts.set(this.points.subarray(3 * i, 3 * i + 3), 3 * j));
      this.freeIndex = keep.length === 0 ? null : keep.length === this.size ? this : new PointCloudIndex(pts, new Uint8Array(keep.length).fill(1));
    }
    return this.freeIndex;
  }

  /** See the rule in the module comment. */
  check(p: readonly number[], options: { k?: number; maxGap?: number } = {}): PointCloudCheck {
    const s = this.score(p, options.k ?? 10);
    const free = this.free();
    const nearestFree = free?.nearest(p, 1).distance[0] ?? Infinity;
    const maxGap = options.maxGap ?? 2 * (free?.typicalSpacing() ?? 0);
    return { ...s, nearestFree, maxGap, ok: nearestFree <= maxGap };
  }
}
