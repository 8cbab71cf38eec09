/**
 * Joint-space geometry of the follower and its safety monitor: differences between joint vectors, the
 * relayed motion at a given time, the nearest point of a segment, and a polyline thinned to the points
 * that matter. Joint vectors are in the twin's `controllable` order (rad or m).
 */
import type { Vec3 } from "@robwot/core";
import type { TrajectoryState } from "./twin.js";

/** The largest joint difference (rad or m) between two joint vectors. */
export function jointGap(a: readonly number[], b: readonly number[]): number {
  return Math.max(0, ...a.map((v, k) => Math.abs(v - (b[k] ?? v))));
}

/** The relayed motion's joints and end-effector position (virtual frame) `t` s after the command. */
export function expectedAt(states: TrajectoryState[], t: number): TrajectoryState | null {
  if (states.length === 0) return null;
  const i = states.findIndex((s) => s.time >= t);
  if (i <= 0) return i === 0 ? states[0]! : states[states.length - 1]!;
  const a = states[i - 1]!;
  const b = states[i]!;
  const f = b.time > a.time ? (t - a.time) / (b.time - a.time) : 1;
  const mix = (x: number[], y: number[]): number[] => x.map((v, k) => v + f * ((y[k] ?? v) - v));
  return { time: t, q: mix(a.q, b.q), position: mix(a.position, b.position) as Vec3 };
}

/** The point of segment `a`-`b` nearest to `p` (Euclidean projection in joint space, clamped to the segment). */
export function nearestOnSegment(p: readonly number[], a: readonly number[], b: readonly number[]): number[] {
  const ab = b.map((v, n) => v - (a[n] ?? v));
  const len2 = ab.reduce((sum, v) => sum + v * v, 0);
  const f = len2 > 0 ? Math.min(1, Math.max(0, p.reduce((sum, v, n) => sum + (v - (a[n] ?? v)) * (ab[n] ?? 0), 0) / len2)) : 0;
  return a.map((v, n) => v + (ab[n] ?? 0) * f);
}

/** The points of a polyline Douglas-Peucker keeps: every dropped point within `tolerance` (largest joint
 * difference) of the segment between the kept points around it; the first and the last kept. */
export function simplify(points: number[][], tolerance: number): number[][] {
  if (points.length <= 2) return points;
  const a = points[0]!;
  const b = points[points.length - 1]!;
  let worst = 0;
  let at = 0;
  for (let k = 1; k < points.length - 1; k++) {
    const d = jointGap(points[k]!, nearestOnSegment(points[k]!, a, b));
    if (d > worst) [worst, at] = [d, k];
  }
  if (worst <= tolerance) return [a, b];
  return [...simplify(points.slice(0, at + 1), tolerance).slice(0, -1), ...simplify(points.slice(at), tolerance)];
}
