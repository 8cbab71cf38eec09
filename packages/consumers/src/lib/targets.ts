/**
 * Deterministic joint targets strictly inside the limits a TD declares, used by the scenarios to pick
 * motions that make sense for any robot (no hard-coded joint names or values).
 */
import type { Twin } from "./connect.js";
import { invoke } from "./connect.js";
import type { Bounds3, JointLimit, Vec3 } from "@robwot/core";
import type { ValidationReport } from "./types.js";

export type Joints = Record<string, number>;

/**
 * `count` targets spread around the middle of each joint's range: joint j of target k sits at
 * `mid + half * fraction * sin(1.7 (k+1)(j+1))`, so targets differ joint by joint and stay within
 * `fraction` of the half range (never on a limit).
 */
export function spreadTargets(limits: JointLimit[], fraction: number, count: number): Joints[] {
  const out: Joints[] = [];
  for (let k = 0; k < count; k++) {
    out.push(
      Object.fromEntries(
        limits.map((l, j) => {
          const mid = (l.lower + l.upper) / 2;
          const half = (l.upper - l.lower) / 2;
          return [l.name, mid + half * fraction * Math.sin(1.7 * (k + 1) * (j + 1))];
        }),
      ),
    );
  }
  return out;
}

export function maxAbsDiff(a: Joints, b: Joints): number {
  return Math.max(...Object.keys(a).map((k) => Math.abs((a[k] ?? NaN) - (b[k] ?? NaN))));
}

/**
 * The first `wanted` candidates the twin's validateJointPosition accepts, skipping any within 1e-3 rad
 * of `skipNear` (the current pose). Rejections are reported through `onReject`.
 */
export async function acceptedTargets(
  twin: Twin,
  candidates: Joints[],
  wanted: number,
  skipNear: Joints | undefined,
  onReject: (target: Joints, reasons: string[]) => void = () => {},
): Promise<Joints[]> {
  const accepted: Joints[] = [];
  for (const candidate of candidates) {
    if (accepted.length >= wanted) break;
    if (skipNear !== undefined && maxAbsDiff(candidate, skipNear) < 1e-3) continue;
    const verdict = await invoke<ValidationReport>(twin, "validateJointPosition", { joints: candidate });
    if (verdict.valid) accepted.push(candidate);
    else onReject(candidate, verdict.reasons);
  }
  return accepted;
}

/**
 * Four stations around the middle of the TD's Cartesian bounds, at 0.45 of the smaller horizontal half
 * extent from it (pick A on +y, place A on -y, pick B on +x, place B on -x), 30 % up from the floor (z = 0,
 * the URDF convention; a workspace sampled without a floor reaches below it); and a corner of the bounding
 * box, inside the bounds the TD declares but outside a roughly round workspace.
 */
export function tableStations(b: Bounds3): { stations: { label: string; p: Vec3 }[]; outOfReach: Vec3 } {
  const c: Vec3 = [(b.min[0] + b.max[0]) / 2, (b.min[1] + b.max[1]) / 2, 0];
  const r = (0.45 * Math.min(b.max[0] - b.min[0], b.max[1] - b.min[1])) / 2;
  const floor = Math.max(b.min[2], 0);
  const z = floor + 0.3 * (b.max[2] - floor);
  const named: [string, number][] = [["pick A", 90], ["place A", -90], ["pick B", 0], ["place B", 180]];
  const stations = named.map(([label, deg]) => {
    const a = (deg * Math.PI) / 180;
    return { label, p: [c[0] + r * Math.cos(a), c[1] + r * Math.sin(a), z] as Vec3 };
  });
  return { stations, outOfReach: [0.95 * b.max[0] + 0.05 * c[0], 0.95 * b.max[1] + 0.05 * c[1], 0.95 * b.max[2] + 0.05 * floor] };
}

