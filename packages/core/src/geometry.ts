/**
 * Vectors, quaternions and rotation matrices: the one home of this maths in TypeScript (servient,
 * consumers and viewer use it). Positions in metres as `Vec3` [x, y, z] or `Xyz` {x, y, z}; quaternions
 * `{x, y, z, w}` or [x, y, z, w] (scalar last, as everywhere in RobWoT); rotation matrices 3x3 row-major.
 * Pure (browser-safe).
 */
import type { Quaternion, Vec3, Xyz } from "./types.js";

export const vec = (p: Xyz): Vec3 => [p.x, p.y, p.z];
export const xyz = (v: readonly number[]): Xyz => ({ x: v[0] ?? 0, y: v[1] ?? 0, z: v[2] ?? 0 });
export const quat = (q: readonly number[]): Quaternion => ({ x: q[0] ?? 0, y: q[1] ?? 0, z: q[2] ?? 0, w: q[3] ?? 1 });
export const quatArr = (q: Quaternion): [number, number, number, number] => [q.x, q.y, q.z, q.w];

export const sub = (a: Vec3, b: Vec3): Vec3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const norm = (a: Vec3): number => Math.hypot(a[0], a[1], a[2]);
export const cross = (a: Vec3, b: Vec3): Vec3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];

export function centroid(points: readonly Vec3[]): Vec3 {
  const s = points.reduce<Vec3>((acc, p) => [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]], [0, 0, 0]);
  return [s[0] / points.length, s[1] / points.length, s[2] / points.length];
}

/** Largest distance of a point from the line through the two farthest-apart points (m). */
export function spreadOffLine(points: readonly Vec3[]): number {
  let best: [Vec3, Vec3] | undefined;
  let bestD = -1;
  for (const a of points) for (const b of points) if (norm(sub(a, b)) > bestD) [bestD, best] = [norm(sub(a, b)), [a, b]];
  if (best === undefined || bestD === 0) return 0;
  const dir = sub(best[1], best[0]);
  return Math.max(...points.map((p) => norm(cross(sub(p, best[0]), dir)) / bestD));
}

/** Hamilton product a ⊗ b (apply b, then a). */
export function quatMul(a: Quaternion, b: Quaternion): Quaternion {
  return {
    w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
    y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
    z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
  };
}

/** The inverse rotation of a unit quaternion. */
export const quatConj = (q: Quaternion): Quaternion => ({ x: -q.x, y: -q.y, z: -q.z, w: q.w });

/** `v` turned by the unit quaternion `q` (q ⊗ v ⊗ q*). */
export function quatRotate(q: Quaternion, v: Vec3): Vec3 {
  const r = quatMul(quatMul(q, { x: v[0], y: v[1], z: v[2], w: 0 }), quatConj(q));
  return [r.x, r.y, r.z];
}

function entry(m: readonly (readonly number[])[], r: number, c: number): number {
  const v = m[r]?.[c];
  if (v === undefined) throw new RangeError("a rotation must be a 3x3 matrix");
  return v;
}

/** Rotation matrix -> unit quaternion (Shepperd's method: the largest of w, x, y, z is found first). */
export function matToQuat(rotation: readonly (readonly number[])[]): Quaternion {
  const m = (r: number, c: number): number => entry(rotation, r, c);
  const tr = m(0, 0) + m(1, 1) + m(2, 2);
  let x: number, y: number, z: number, w: number;
  if (tr > 0) {
    const s = Math.sqrt(tr + 1) * 2;
    [w, x, y, z] = [s / 4, (m(2, 1) - m(1, 2)) / s, (m(0, 2) - m(2, 0)) / s, (m(1, 0) - m(0, 1)) / s];
  } else if (m(0, 0) > m(1, 1) && m(0, 0) > m(2, 2)) {
    const s = Math.sqrt(1 + m(0, 0) - m(1, 1) - m(2, 2)) * 2;
    [w, x, y, z] = [(m(2, 1) - m(1, 2)) / s, s / 4, (m(0, 1) + m(1, 0)) / s, (m(0, 2) + m(2, 0)) / s];
  } else if (m(1, 1) > m(2, 2)) {
    const s = Math.sqrt(1 + m(1, 1) - m(0, 0) - m(2, 2)) * 2;
    [w, x, y, z] = [(m(0, 2) - m(2, 0)) / s, (m(0, 1) + m(1, 0)) / s, s / 4, (m(1, 2) + m(2, 1)) / s];
  } else {
    const s = Math.sqrt(1 + m(2, 2) - m(0, 0) - m(1, 1)) * 2;
    [w, x, y, z] = [(m(1, 0) - m(0, 1)) / s, (m(0, 2) + m(2, 0)) / s, (m(1, 2) + m(2, 1)) / s, s / 4];
  }
  const n = Math.hypot(x, y, z, w);
  return { x: x / n, y: y / n, z: z / n, w: w / n };
}

/** Rotation angle (rad, in [0, π]) and unit axis of a rotation matrix (z for no rotation). */
export function axisAngle(rotation: readonly (readonly number[])[]): { angle: number; axis: Vec3 } {
  const m = (r: number, c: number): number => entry(rotation, r, c);
  const angle = Math.acos(Math.min(1, Math.max(-1, (m(0, 0) + m(1, 1) + m(2, 2) - 1) / 2)));
  const v: Vec3 = [m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1)];
  const n = norm(v);
  return { angle, axis: n > 1e-12 ? [v[0] / n, v[1] / n, v[2] / n] : [0, 0, 1] };
}
