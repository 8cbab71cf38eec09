/**
 * Small vector helpers for the calibration scenario. Calibration (paper eq. 1):
 * x_real = s · R · x_virtual + t, R a 3x3 rotation (row-major), t in metres.
 */
import type { Xyz } from "./types.js";

export type V3 = [number, number, number];

export const toV3 = (p: Xyz): V3 => [p.x, p.y, p.z];
export const toXyz = (v: V3): Xyz => ({ x: v[0], y: v[1], z: v[2] });
export const sub = (a: V3, b: V3): V3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const norm = (a: V3): number => Math.hypot(a[0], a[1], a[2]);
export const cross = (a: V3, b: V3): V3 => [
  a[1] * b[2] - a[2] * b[1],
  a[2] * b[0] - a[0] * b[2],
  a[0] * b[1] - a[1] * b[0],
];

export function centroid(points: V3[]): V3 {
  const s = points.reduce<V3>((acc, p) => [acc[0] + p[0], acc[1] + p[1], acc[2] + p[2]], [0, 0, 0]);
  return [s[0] / points.length, s[1] / points.length, s[2] / points.length];
}

/** Largest distance of a point from the line through the two farthest-apart points (m). */
export function spreadOffLine(points: V3[]): number {
  let best: [V3, V3] | undefined;
  let bestD = -1;
  for (const a of points) for (const b of points) if (norm(sub(a, b)) > bestD) [bestD, best] = [norm(sub(a, b)), [a, b]];
  if (best === undefined || bestD === 0) return 0;
  const dir = sub(best[1], best[0]);
  return Math.max(...points.map((p) => norm(cross(sub(p, best[0]), dir)) / bestD));
}

function row(m: number[][], i: number): V3 {
  const r = m[i];
  if (r === undefined || r.length !== 3) throw new Error(`rotation row ${i} is not 3 numbers`);
  return [r[0] as number, r[1] as number, r[2] as number];
}

/** Rotation angle (rad) and unit axis of a rotation matrix. */
export function axisAngle(rotation: number[][]): { angle: number; axis: V3 } {
  const [r0, r1, r2] = [row(rotation, 0), row(rotation, 1), row(rotation, 2)];
  const trace = r0[0] + r1[1] + r2[2];
  const angle = Math.acos(Math.min(1, Math.max(-1, (trace - 1) / 2)));
  const v: V3 = [r2[1] - r1[2], r0[2] - r2[0], r1[0] - r0[1]];
  const n = norm(v);
  return { angle, axis: n > 1e-12 ? [v[0] / n, v[1] / n, v[2] / n] : [0, 0, 1] };
}
