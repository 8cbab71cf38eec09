/** Topology checks of a triangle soup (vertices welded by exact coordinates). Pure. */

export interface MeshTopology {
  vertices: number;
  edges: number;
  /** undirected edges used by exactly one triangle */
  boundaryEdges: number;
  /** undirected edges used by more than two triangles */
  nonManifoldEdges: number;
  /** edges whose two triangles traverse them in the same direction (inconsistent winding) */
  misorientedEdges: number;
  degenerateTriangles: number;
}

export function meshTopology(tri: Float64Array): MeshTopology {
  const ids = new Map<string, number>();
  const n = tri.length / 9;
  const vid = new Int32Array(3 * n);
  for (let k = 0; k < 3 * n; k++) {
    const key = `${tri[3 * k]},${tri[3 * k + 1]},${tri[3 * k + 2]}`;
    let id = ids.get(key);
    if (id === undefined) {
      id = ids.size;
      ids.set(key, id);
    }
    vid[k] = id;
  }
  // per undirected edge: [uses, forward uses (low -> high)]
  const edges = new Map<number, [number, number]>();
  const nv = ids.size;
  let degenerate = 0;
  for (let t = 0; t < n; t++) {
    const a = vid[3 * t]!, b = vid[3 * t + 1]!, c = vid[3 * t + 2]!;
    if (a === b || b === c || a === c) {
      degenerate++;
      continue;
    }
    for (const [p, q] of [[a, b], [b, c], [c, a]] as const) {
      const key = Math.min(p, q) * nv + Math.max(p, q);
      const e = edges.get(key) ?? [0, 0];
      e[0]++;
      if (p < q) e[1]++;
      edges.set(key, e);
    }
  }
  let boundary = 0, nonManifold = 0, misoriented = 0;
  for (const [uses, forward] of edges.values()) {
    if (uses === 1) boundary++;
    else if (uses > 2) nonManifold++;
    else if (forward !== 1) misoriented++;
  }
  return { vertices: nv, edges: edges.size, boundaryEdges: boundary, nonManifoldEdges: nonManifold, misorientedEdges: misoriented, degenerateTriangles: degenerate };
}

/** Signed volume (m³) by the divergence theorem: positive when normals point outward. */
export function signedVolume(tri: Float64Array): number {
  let v = 0;
  for (let o = 0; o < tri.length; o += 9) {
    const ax = tri[o]!, ay = tri[o + 1]!, az = tri[o + 2]!;
    const bx = tri[o + 3]!, by = tri[o + 4]!, bz = tri[o + 5]!;
    const cx = tri[o + 6]!, cy = tri[o + 7]!, cz = tri[o + 8]!;
    v += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
  }
  return v / 6;
}
