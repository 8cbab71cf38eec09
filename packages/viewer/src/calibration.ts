/**
 * The twin's active calibration (Contract 3 `calibration` property): x_real = s·R·x_virtual + t. Cartesian
 * inputs and outputs of the TD are in the real frame when it is active; the 3D view is in the virtual
 * (simulation) frame, so markers placed from Cartesian inputs go through `realToVirtual`.
 */
import { invertCalibration } from "@robwot/core/browser";
import { isRecord } from "./http.js";

export interface Calibration {
  scale: number;
  /** 3x3 row-major */
  rotation: number[][];
  translation: [number, number, number];
}

export function parseCalibration(c: unknown): Calibration | null {
  if (!isRecord(c) || c["active"] !== true) return null;
  const { scale, rotation, translation } = c;
  const row = (r: unknown): r is number[] => Array.isArray(r) && r.length === 3 && r.every((v) => typeof v === "number");
  if (typeof scale !== "number" || !(scale > 0) || !Array.isArray(rotation) || rotation.length !== 3 || !rotation.every(row) || !row(translation)) {
    return null;
  }
  return { scale, rotation, translation: [translation[0] as number, translation[1] as number, translation[2] as number] };
}

/** x_virtual = Rᵀ (x_real − t) / s (core's inverse of the calibration) */
export function realToVirtual(c: Calibration, p: { x: number; y: number; z: number }): [number, number, number] {
  return invertCalibration(c, p);
}
