/** Generated test geometry: icospheres, boxes, shells, seeded random points. */

import { gaussian, mulberry32 } from "../random.js";

/** Seeded uniform numbers in [0, 1) (mulberry32). */
export const rng = mulberry32;
/** Standard normal sample (Box-Muller). */
export const gauss = gaussian;

/** Icosphere (outward, counter-clockwise seen from outside); subdivisions s gives 20·4^s triangles. */
export function icosphere(subdivisions: number, radius = 1, center: readonly number[] = [0, 0, 0]): Float64Array {
  const t = (1 + Math.sqrt(5)) / 2;
  let verts: number[][] = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]];
  let faces: number[][] = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]];
  const norm = (v: number[]): number[] => {
    const l = Math.hypot(v[0]!, v[1]!, v[2]!);
    return v.map((x) => x / l);
  };
  verts = verts.map(norm);
  for (let s = 0; s < subdivisions; s++) {
    const mid = new Map<string, number>();
    const m = (a: number, b: number): number => {
      const key = a < b ? `${a}_${b}` : `${b}_${a}`;
      let i = mid.get(key);
      if (i === undefined) {
        i = verts.length;
        verts.push(norm([0, 1, 2].map((k) => (verts[a]![k]! + verts[b]![k]!) / 2)));
        mid.set(key, i);
      }
      return i;
    };
    faces = faces.flatMap(([a, b, c]) => {
      const ab = m(a!, b!), bc = m(b!, c!), ca = m(c!, a!);
      return [[a!, ab, ca], [b!, bc, ab], [c!, ca, bc], [ab, bc, ca]];
    });
  }
  const out = new Float64Array(faces.length * 9);
  faces.forEach((f, i) => f.forEach((v, j) => [0, 1, 2].forEach((k) => (out[9 * i + 3 * j + k] = verts[v]![k]! * radius + center[k]!))));
  return out;
}

/** Reverses the winding (normals inward). */
export function flip(tri: Float64Array): Float64Array {
  const out = tri.slice();
  for (let o = 0; o < tri.length; o += 9) for (let k = 0; k < 3; k++) [out[o + 3 + k], out[o + 6 + k]] = [tri[o + 6 + k]!, tri[o + 3 + k]!];
  return out;
}

export function concat(...parts: Float64Array[]): Float64Array {
  const out = new Float64Array(parts.reduce((n, p) => n + p.length, 0));
  let o = 0;
  for (const p of parts) {
    out.set(p, o);
    o += p.length;
  }
  return out;
}

/** Axis-aligned box [min, max], 12 outward triangles (each face split along a diagonal). */
export function box(min: readonly number[], max: readonly number[]): Float64Array {
  const c = (i: number): number[] => [i & 1 ? max[0]! : min[0]!, i & 2 ? max[1]! : min[1]!, i & 4 ? max[2]! : min[2]!];
  const quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
  return Float64Array.from(quads.flatMap(([a, b, cc, d]) => [a!, b!, cc!, a!, cc!, d!].flatMap((i) => c(i))));
}

/** n points uniform in a ball. */
export function ballPoints(n: number, radius: number, r: () => number): Float64Array {
  const out = new Float64Array(3 * n);
  for (let i = 0; i < n; ) {
    const p = [0, 1, 2].map(() => (2 * r() - 1) * radius);
    if (Math.hypot(p[0]!, p[1]!, p[2]!) > radius) continue;
    out.set(p, 3 * i++);
  }
  return out;
}
