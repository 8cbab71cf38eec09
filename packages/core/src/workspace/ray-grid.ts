/**
 * Ray-parity acceleration for point-in-mesh: for one axis a, triangles are binned by their projection
 * onto the plane of the two other axes (u, v) in a uniform 2D grid. A ray from p along +a can only hit
 * the triangles of p's cell. Point-in-projected-triangle uses exactly antisymmetric edge functions and
 * the top-left rule, so a ray through a shared edge or vertex is counted once (parity stays exact on a
 * closed mesh). Pure.
 */

const AXES: readonly [number, number][] = [
  [1, 2], // ray along x: plane (y, z)
  [2, 0], // ray along y: plane (z, x)
  [0, 1], // ray along z: plane (x, y)
];

/** orient(P, Q, X) computed with the endpoints in a canonical order, so orient(P,Q,X) === -orient(Q,P,X). */
function edgeFn(pu: number, pv: number, qu: number, qv: number, xu: number, xv: number): number {
  if (pu > qu || (pu === qu && pv > qv)) return -((pu - qu) * (xv - qv) - (pv - qv) * (xu - qu));
  return (qu - pu) * (xv - pv) - (qv - pv) * (xu - pu);
}

/** Top-left rule: exactly one of P→Q and Q→P owns the points lying on the edge. */
function owns(pu: number, pv: number, qu: number, qv: number): boolean {
  const dv = qv - pv;
  return dv < 0 || (dv === 0 && qu - pu < 0);
}

export class RayGrid {
  private readonly u: number;
  private readonly v: number;
  private readonly a: number;
  private readonly u0: number;
  private readonly v0: number;
  private readonly nu: number;
  private readonly nv: number;
  private readonly cu: number;
  private readonly cv: number;
  private readonly start: Int32Array;
  private readonly items: Int32Array;

  constructor(private readonly tri: Float64Array, axis: 0 | 1 | 2, min: readonly number[], max: readonly number[]) {
    const [u, v] = AXES[axis]!;
    this.u = u;
    this.v = v;
    this.a = axis;
    const n = tri.length / 9;
    const du = Math.max(max[u]! - min[u]!, 1e-12);
    const dv = Math.max(max[v]! - min[v]!, 1e-12);
    const cells = Math.min(Math.max(n, 1), 1 << 22);
    this.nu = Math.max(1, Math.min(4096, Math.round(Math.sqrt((cells * du) / dv))));
    this.nv = Math.max(1, Math.min(4096, Math.round(cells / this.nu)));
    this.u0 = min[u]!;
    this.v0 = min[v]!;
    this.cu = du / this.nu;
    this.cv = dv / this.nv;
    const counts = new Int32Array(this.nu * this.nv + 1);
    const range = (t: number): [number, number, number, number] => {
      const o = 9 * t;
      const us = [tri[o + u]!, tri[o + 3 + u]!, tri[o + 6 + u]!];
      const vs = [tri[o + v]!, tri[o + 3 + v]!, tri[o + 6 + v]!];
      return [this.cellU(Math.min(...us)), this.cellU(Math.max(...us)), this.cellV(Math.min(...vs)), this.cellV(Math.max(...vs))];
    };
    for (let t = 0; t < n; t++) {
      const [i0, i1, j0, j1] = range(t);
      for (let i = i0; i <= i1; i++) for (let j = j0; j <= j1; j++) counts[i * this.nv + j]!++;
    }
    this.start = new Int32Array(this.nu * this.nv + 1);
    for (let c = 0; c < this.nu * this.nv; c++) this.start[c + 1] = this.start[c]! + counts[c]!;
    this.items = new Int32Array(this.start[this.nu * this.nv]!);
    const fill = this.start.slice(0, this.nu * this.nv);
    for (let t = 0; t < n; t++) {
      const [i0, i1, j0, j1] = range(t);
      for (let i = i0; i <= i1; i++) for (let j = j0; j <= j1; j++) this.items[fill[i * this.nv + j]!++] = t;
    }
  }

  private cellU(x: number): number {
    return Math.min(this.nu - 1, Math.max(0, Math.floor((x - this.u0) / this.cu)));
  }
  private cellV(x: number): number {
    return Math.min(this.nv - 1, Math.max(0, Math.floor((x - this.v0) / this.cv)));
  }

  /** Number of triangles the ray from (x, y, z) along +axis crosses strictly beyond the point. */
  crossings(p: readonly number[]): number {
    const { tri, u, v, a } = this;
    const pu = p[u]!, pv = p[v]!, pa = p[a]!;
    const fi = Math.floor((pu - this.u0) / this.cu);
    const fj = Math.floor((pv - this.v0) / this.cv);
    if (fi < 0 || fj < 0 || fi > this.nu || fj > this.nv) return 0;
    const c = Math.min(fi, this.nu - 1) * this.nv + Math.min(fj, this.nv - 1);
    let count = 0;
    for (let k = this.start[c]!; k < this.start[c + 1]!; k++) {
      const o = 9 * this.items[k]!;
      const au = tri[o + u]!, av = tri[o + v]!, ah = tri[o + a]!;
      let bu = tri[o + 3 + u]!, bv = tri[o + 3 + v]!, bh = tri[o + 3 + a]!;
      let cu = tri[o + 6 + u]!, cv = tri[o + 6 + v]!, ch = tri[o + 6 + a]!;
      const area = edgeFn(au, av, bu, bv, cu, cv);
      if (area === 0) continue; // parallel to the ray: its neighbours decide
      if (area < 0) {
        [bu, cu] = [cu, bu];
        [bv, cv] = [cv, bv];
        [bh, ch] = [ch, bh];
      }
      const wa = edgeFn(bu, bv, cu, cv, pu, pv);
      if (wa < 0 || (wa === 0 && !owns(bu, bv, cu, cv))) continue;
      const wb = edgeFn(cu, cv, au, av, pu, pv);
      if (wb < 0 || (wb === 0 && !owns(cu, cv, au, av))) continue;
      const wc = edgeFn(au, av, bu, bv, pu, pv);
      if (wc < 0 || (wc === 0 && !owns(au, av, bu, bv))) continue;
      const sum = wa + wb + wc;
      if (sum <= 0) continue;
      const h = (wa * ah + wb * bh + wc * ch) / sum;
      if (h > pa) count++;
    }
    return count;
  }
}
