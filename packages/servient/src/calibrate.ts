/**
 * The `calibrate` action and calibration persistence: solves x_real = s·R·x_virtual + t from >= 3
 * non-collinear point pairs with core's Kabsch-Umeyama solver (with or without scale), writes
 * `calibration.json` into the twin folder atomically (temp file + rename), and applies it to every
 * Cartesian input and output of the twin from then on. Degenerate input answers 400 (`E_CALIBRATION`).
 */
import { renameSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { type CalibrationFile, FrameMap, solveCalibration, TWIN_FILES, vec, type Vec3, type Xyz } from "@robwot/core";
import { badInput } from "./errors.js";
import type { Twin } from "./twin.js";

export interface CalibrateInput {
  pairs: { real: Xyz; virtual: Xyz }[];
  withScale?: boolean;
}

export interface CalibrationResult {
  scale: number;
  rotation: number[][];
  translation: Vec3;
  rms: number;
  pairs: number;
}

export function calibrationProperty(cal: CalibrationFile | null): Record<string, unknown> {
  return cal ? { active: true, ...cal } : { active: false };
}

export function writeCalibration(dir: string, cal: CalibrationFile): void {
  const file = join(dir, TWIN_FILES.calibration);
  const tmp = `${file}.tmp-${process.pid}-${Date.now()}`;
  writeFileSync(tmp, `${JSON.stringify(cal, null, 2)}\n`);
  renameSync(tmp, file);
}

export function calibrate(twin: Twin, input: CalibrateInput): CalibrationResult {
  if (!Array.isArray(input.pairs) || input.pairs.length < 3) {
    throw badInput(`calibration needs at least 3 point pairs, got ${Array.isArray(input.pairs) ? input.pairs.length : 0}`, {
      param: "pairs",
      minimum: 3,
    });
  }
  const withScale = input.withScale ?? true;
  // core throws CalibrationError (E_CALIBRATION: collinear, coincident, non-finite) -> 400
  const sol = solveCalibration(
    input.pairs.map((p) => ({ real: vec(p.real), virtual: vec(p.virtual) })),
    { withScale },
  );
  const file: CalibrationFile = {
    scale: sol.scale,
    rotation: sol.rotation.map((r) => [...r]),
    translation: [...sol.translation] as Vec3,
    rms: sol.rms,
    pairs: input.pairs.length,
    withScale,
    createdAt: new Date().toISOString(),
  };
  writeCalibration(twin.folder.dir, file);
  twin.folder.calibration = file;
  twin.frames = new FrameMap(file);
  twin.emit("joints", twin.liveJoints());
  return { scale: file.scale, rotation: file.rotation, translation: file.translation, rms: file.rms, pairs: file.pairs };
}
