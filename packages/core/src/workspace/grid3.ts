/**
 * Shared machinery of the uniform 3D grids (surface distance, point-cloud kNN): ring enumeration around
 * a query cell, an empty-space skip (Chebyshev distance of every cell to the nearest non-empty cell) and
 * the exact lower bound on the distance to anything not yet visited. Pure.
 */

export type Dims = [number, number, number];

/** Multi-source BFS over the 26-neighbourhood: grid steps (L∞) from each cell to the nearest non-empty one. */
export function emptySkipField(start: Int32Array, n: Dims): Int32Array {
  const cells = n[0] * n[1] * n[2];
  const dist = new Int32Array(cells).fill(-1);
  let frontier: number[] = [];
  for (let c = 0; c < cells; c++) {
    if (start[c + 1]! > start[c]!) {
      dist[c] = 0;
      frontier.push(c);
    }
  }
  for (let d = 1; frontier.length > 0; d++) {
    const next: number[] = [];
    for (const c of frontier) {
      const l = c % n[2], j = Math.floor(c / n[2]) % n[1], i = Math.floor(c / (n[1] * n[2]));
      for (let di = -1; di <= 1; di++) {
        const ii = i + di;
        if (ii < 0 || ii >= n[0]) continue;
        for (let dj = -1; dj <= 1; dj++) {
          const jj = j + dj;
          if (jj < 0 || jj >= n[1]) continue;
          for (let dl = -1; dl <= 1; dl++) {
            const ll = l + dl;
            if (ll < 0 || ll >= n[2]) continue;
            const cc = (ii * n[1] + jj) * n[2] + ll;
            if (dist[cc] === -1) {
              dist[cc] = d;
              next.push(cc);
            }
          }
        }
      }
    }
    frontier = next;
  }
  return dist;
}

export class Grid3 {
  readonly n: Dims;
  private readonly skip: Int32Array;

  /**
   * @param min grid origin
   * @param cell cell edge length
   * @param n cells per axis
   * @param start CSR offsets (length cells + 1) of the items binned per cell
   */
  constructor(readonly min: readonly number[], readonly cell: number, n: Dims, readonly start: Int32Array) {
    this.n = n;
    this.skip = emptySkipField(start, n);
  }

  /**
   * Visits cells ring by ring (L∞ rings of cells around p's cell), starting at the first ring that can hold
   * an item. Before each ring, calls `bound(lowerBound)`: the distance from p below which everything has
   * been visited; when it returns false the search stops.
   */
  search(p: readonly number[], visitCell: (cell: number) => void, keepGoing: (visitedRadius: number) => boolean): void {
    const [n0, n1, n2] = this.n;
    const c = [0, 1, 2].map((k) => Math.floor((p[k]! - this.min[k]!) / this.cell)) as Dims;
    const cc = [0, 1, 2].map((k) => Math.min(this.n[k]! - 1, Math.max(0, c[k]!))) as Dims;
    const out = Math.max(...[0, 1, 2].map((k) => Math.abs(c[k]! - cc[k]!)));
    const d = this.skip[(cc[0] * n1 + cc[1]) * n2 + cc[2]]!;
    if (d < 0) return; // empty grid
    let r = Math.max(out, d - out);
    const rMax = out + Math.max(n0, n1, n2);
    for (; r <= rMax; r++) {
      if (!keepGoing(this.visitedRadius(p, c, r))) return;
      const lLo = Math.max(0, c[2] - r), lHi = Math.min(n2 - 1, c[2] + r);
      for (let i = Math.max(0, c[0] - r); i <= Math.min(n0 - 1, c[0] + r); i++) {
        for (let j = Math.max(0, c[1] - r); j <= Math.min(n1 - 1, c[1] + r); j++) {
          const base = (i * n1 + j) * n2;
          if (r === 0 || i === c[0] - r || i === c[0] + r || j === c[1] - r || j === c[1] + r) {
            for (let l = lLo; l <= lHi; l++) visitCell(base + l);
          } else {
            if (c[2] - r >= 0 && c[2] - r < n2) visitCell(base + c[2] - r);
            if (c[2] + r >= 0 && c[2] + r < n2) visitCell(base + c[2] + r);
          }
        }
      }
    }
  }

  /** Distance from p to the nearest grid cell not in rings 0..r-1 (Infinity when none is left). */
  private visitedRadius(p: readonly number[], c: Dims, r: number): number {
    if (r === 0) return 0;
    let bound = Infinity;
    for (let k = 0; k < 3; k++) {
      const lo = c[k]! - r + 1, hi = c[k]! + r; // visited cells span [lo, hi) on axis k
      if (lo > 0) bound = Math.min(bound, p[k]! - (this.min[k]! + lo * this.cell));
      if (hi < this.n[k]!) bound = Math.min(bound, this.min[k]! + hi * this.cell - p[k]!);
    }
    return Math.max(0, bound);
  }
}
