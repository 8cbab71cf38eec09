/**
 * Deterministic joint targets strictly inside the limits a TD declares, used by the scenarios to pick
 * motions that make sense for any robot (no hard-coded joint names or values).
 */
import type { Twin } from "./connect.js";
import { invoke } from "./connect.js";
import type { JointLimit } from "@robwot/core";
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
