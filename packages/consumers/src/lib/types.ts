/**
 * Data shapes of the twin's affordances as a consumer sees them (ARCHITECTURE.md Contract 3), taken
 * from @robwot/core so producer and consumers cannot drift apart.
 */
export type { MotionStatus, MoveOutput, ValidationReport, CollisionEvent, Xyz, Quaternion } from "@robwot/core";
import type { Quaternion, Xyz } from "@robwot/core";

/** A move result from a twin served with `--relay`: what the physical robot's Thing answered. */
export type { RelayedMoveOutput } from "@robwot/core";

/** `getCartesianPosition` value. */
export interface CartesianPose extends Xyz {
  orientation: Quaternion;
}

/** `calibrate` output. */
export interface CalibrationResult {
  scale: number;
  rotation: number[][];
  translation: number[];
  rms: number;
  pairs: number;
}

/** `calibration` property: the active calibration or `{active: false}`. */
export type CalibrationState =
  | { active: false }
  | ({ active?: true; scale: number; rotation: number[][]; translation: number[] } & Record<string, unknown>);
