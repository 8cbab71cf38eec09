/**
 * Virtual-to-real calibration (paper eq. 1): x_real = s · R · x_virtual + t, solved in the least-squares
 * sense with Umeyama's method (IEEE PAMI 13(4), 1991): SVD of the cross-covariance of the centred point
 * sets, with the reflection fix (S = diag(1, 1, -1) when det(U)·det(V) < 0) so R is a proper rotation.
 * Without scale (withScale false) s = 1 (Kabsch). Pure (browser-safe).
 */
import { Matrix, SingularValueDecomposition, determinant } from "ml-matrix";
import { CalibrationError, InvalidArgumentError } from "./errors.js";
import { matToQuat, quatConj, quatMul } from "./geometry.js";
import type { Bounds, Quaternion, Vec3, Xyz } from "./types.js";

export type PointLike = Vec3 | Xyz;

export interface CalibrationPair {
  real: PointLike;
  virtual: PointLike;
}

export interface Calibration {
  scale: number;
  /** 3x3 row-major, orthonormal, det +1 */
  rotation: number[][];
  translation: Vec3;
  /** root-mean-square residual |s·R·v + t - r| over the pairs (m) */
  rms: number;
  /** number of pairs used */
  pairs: number;
  withScale: boolean;
  /** per-pair residual (m), in input order */
  residuals: number[];
}

/** Points whose second principal spread is below this fraction of the first count as collinear. */
export const COLLINEAR_RATIO = 1e-3;
/** RMS spread (m) below which a point set counts as coincident. */
export const COINCIDENT_SPREAD = 1e-9;
/** Largest |coordinate| (m) of a calibration point: a robot cell is metres, not kilometres. */
export const MAX_CALIBRATION_COORDINATE = 1e3;
/** Accepted similarity scale: outside, the real points are in other units (mm?) or mismatched. */
export const CALIBRATION_SCALE_RANGE = [0.5, 2] as const;
/** Largest RMS residual (m) of an accepted fit: above, the pairs do not describe one rigid placement. */
export const MAX_CALIBRATION_RMS = 0.05;

function toVec3(p: PointLike, where: string): Vec3 {
  const v: unknown[] = Array.isArray(p) ? p : p && typeof p === "object" ? [p.x, p.y, p.z] : [];
  if (v.length !== 3 || !v.every((x) => typeof x === "number" && Number.isFinite(x))) {
    throw new CalibrationError(`${where} must be 3 finite numbers, got ${JSON.stringify(p)}`, { where, got: p ?? null });
  }
  if (v.some((x) => Math.abs(x as number) > MAX_CALIBRATION_COORDINATE)) {
    throw new CalibrationError(`${where} lies beyond ${MAX_CALIBRATION_COORDINATE} m (coordinates are metres)`, {
      reason: "out-of-range",
      where,
      got: p ?? null,
      limit: MAX_CALIBRATION_COORDINATE,
    });
  }
  return v as Vec3;
}

/** Singular values (descending) of the centred points divided by sqrt(n): RMS spread along the principal axes (m). */
function principalSpread(centred: Matrix): number[] {
  const n = centred.rows;
  return new SingularValueDecomposition(centred, { computeLeftSingularVectors: false, computeRightSingularVectors: false }).diagonal.map((s) => s / Math.sqrt(n));
}

function checkSpread(centred: Matrix, side: "virtual" | "real"): void {
  const [s1 = 0, s2 = 0] = principalSpread(centred);
  if (s1 < COINCIDENT_SPREAD) {
    throw new CalibrationError(`the ${side} points coincide (RMS spread ${s1.toExponential(2)} m): scale and rotation are undetermined`, {
      reason: "coincident",
      side,
      spread: [s1, s2],
    });
  }
  if (s2 < COLLINEAR_RATIO * s1) {
    throw new CalibrationError(
      `the ${side} points are collinear (spread across the line ${s2.toExponential(2)} m vs ${s1.toPrecision(3)} m along it): the rotation about that line is undetermined; use at least 3 points not on one line`,
      { reason: "collinear", side, spread: [s1, s2], ratio: s2 / s1, minRatio: COLLINEAR_RATIO },
    );
  }
}

export function solveCalibration(pairs: readonly CalibrationPair[], options: { withScale?: boolean } = {}): Calibration {
  const withScale = options.withScale ?? true;
  if (!Array.isArray(pairs) || pairs.length < 3) {
    throw new CalibrationError(`calibration needs at least 3 point pairs, got ${Array.isArray(pairs) ? pairs.length : typeof pairs}`, {
      reason: "too-few-pairs",
      got: Array.isArray(pairs) ? pairs.length : null,
      min: 3,
    });
  }
  const n = pairs.length;
  const real = pairs.map((p, i) => toVec3(p?.real, `pairs[${i}].real`));
  const virt = pairs.map((p, i) => toVec3(p?.virtual, `pairs[${i}].virtual`));
  const X = new Matrix(virt);
  const Y = new Matrix(real);
  const muX = X.mean("column");
  const muY = Y.mean("column");
  const Xc = X.clone().subRowVector(muX);
  const Yc = Y.clone().subRowVector(muY);
  checkSpread(Xc, "virtual");
  checkSpread(Yc, "real");

  const varX = Xc.clone().pow(2).sum() / n;
  const cov = Yc.transpose().mmul(Xc).div(n); // Σxy = 1/n Σ (y - μy)(x - μx)ᵀ
  const svd = new SingularValueDecomposition(cov);
  const U = svd.leftSingularVectors;
  const V = svd.rightSingularVectors;
  const D = svd.diagonal;
  const S = [1, 1, determinant(U) * determinant(V) < 0 ? -1 : 1];
  const R = U.mmul(Matrix.diag(S)).mmul(V.transpose());
  const scale = withScale ? (D[0]! * S[0]! + D[1]! * S[1]! + D[2]! * S[2]!) / varX : 1;
  if (!(scale > 0) || !Number.isFinite(scale)) {
    throw new CalibrationError(`the point pairs give a non-positive scale (${scale}): the real points do not match the virtual ones`, { reason: "bad-scale", scale });
  }
  const rotation = R.to2DArray();
  const rmu = R.mmul(Matrix.columnVector(muX)).to1DArray();
  const translation: Vec3 = [0, 1, 2].map((k) => muY[k]! - scale * rmu[k]!) as Vec3;
  const cal = { scale, rotation, translation };
  const residuals = virt.map((v, i) => {
    const q = applyCalibration(cal, v);
    const r = real[i]!;
    return Math.hypot(q[0] - r[0], q[1] - r[1], q[2] - r[2]);
  });
  const rms = Math.sqrt(residuals.reduce((a, e) => a + e * e, 0) / n);
  const [lo, hi] = CALIBRATION_SCALE_RANGE;
  if (scale < lo || scale > hi) {
    throw new CalibrationError(`the fitted scale ${scale.toPrecision(4)} is outside [${lo}, ${hi}]: are the real points in metres, and paired with the right virtual points?`, {
      reason: "scale-out-of-range",
      scale,
      range: [lo, hi],
    });
  }
  if (rms > MAX_CALIBRATION_RMS) {
    throw new CalibrationError(`the pairs do not fit one placement: RMS residual ${rms.toPrecision(3)} m > ${MAX_CALIBRATION_RMS} m (check the pairing order and the measurements)`, {
      reason: "residual",
      rms,
      limit: MAX_CALIBRATION_RMS,
      residuals,
    });
  }
  return { scale, rotation, translation, rms, pairs: n, withScale, residuals };
}

/**
 * Checks a stored calibration (calibration.json) before it is used: finite values, scale within
 * CALIBRATION_SCALE_RANGE, a proper rotation (orthonormal, determinant +1, within 1e-6), translation
 * within MAX_CALIBRATION_COORDINATE. Throws CalibrationError naming the offending field.
 */
export function checkCalibration(cal: unknown): Transform {
  const c = (cal ?? {}) as Partial<Record<"scale" | "rotation" | "translation", unknown>>;
  const fail = (field: string, why: string): never => {
    throw new CalibrationError(`${field} ${why}`, { reason: "bad-file", field });
  };
  const [lo, hi] = CALIBRATION_SCALE_RANGE;
  if (typeof c.scale !== "number" || !Number.isFinite(c.scale) || c.scale < lo || c.scale > hi) fail("scale", `must be a number in [${lo}, ${hi}], got ${JSON.stringify(c.scale ?? null)}`);
  const R = c.rotation;
  if (!Array.isArray(R) || R.length !== 3 || !R.every((r) => Array.isArray(r) && r.length === 3 && r.every((x) => typeof x === "number" && Number.isFinite(x)))) {
    fail("rotation", "must be a 3x3 matrix of finite numbers");
  }
  const m = new Matrix(R as number[][]);
  const err = m.transpose().mmul(m).sub(Matrix.eye(3)).abs().max();
  if (err > 1e-6 || determinant(m) < 0) fail("rotation", `is not a rotation (|RᵀR - I| = ${err.toExponential(2)}, det ${determinant(m).toFixed(3)})`);
  const t = c.translation;
  if (!Array.isArray(t) || t.length !== 3 || !t.every((x) => typeof x === "number" && Number.isFinite(x) && Math.abs(x) <= MAX_CALIBRATION_COORDINATE)) {
    fail("translation", `must be 3 finite numbers within ${MAX_CALIBRATION_COORDINATE} m`);
  }
  return { scale: c.scale as number, rotation: R as number[][], translation: t as Vec3 };
}

type Transform = SimilarityTransform;

function rot(cal: Transform, r: number, c: number): number {
  const v = cal.rotation[r]?.[c];
  if (v === undefined) throw new InvalidArgumentError("calibration rotation must be a 3x3 matrix", { param: "rotation", got: cal.rotation });
  return v;
}

/** Virtual (twin) frame to real frame: s·R·p + t. */
export function applyCalibration(cal: Transform, p: PointLike): Vec3 {
  const v = toVec3(p, "point");
  return [0, 1, 2].map((r) => cal.scale * (rot(cal, r, 0) * v[0] + rot(cal, r, 1) * v[1] + rot(cal, r, 2) * v[2]) + cal.translation[r]!) as Vec3;
}

/** Real frame to virtual (twin) frame: Rᵀ·(p - t) / s. */
export function invertCalibration(cal: Transform, p: PointLike): Vec3 {
  const v = toVec3(p, "point");
  const d = [v[0] - cal.translation[0], v[1] - cal.translation[1], v[2] - cal.translation[2]];
  return [0, 1, 2].map((c) => (rot(cal, 0, c) * d[0]! + rot(cal, 1, c) * d[1]! + rot(cal, 2, c) * d[2]!) / cal.scale) as Vec3;
}

/** A similarity transform x_real = scale · rotation · x_virtual + translation (rotation 3x3 row-major). */
export interface SimilarityTransform {
  scale: number;
  rotation: number[][];
  translation: Vec3;
}

/** Axis-aligned box of the transformed corners of `b`. */
export function transformBounds(b: Bounds, t: SimilarityTransform): Bounds {
  const min: Vec3 = [Infinity, Infinity, Infinity];
  const max: Vec3 = [-Infinity, -Infinity, -Infinity];
  for (let c = 0; c < 8; c++) {
    const p = applyCalibration(t, [c & 1 ? b.max[0] : b.min[0], c & 2 ? b.max[1] : b.min[1], c & 4 ? b.max[2] : b.min[2]]);
    for (let r = 0; r < 3; r++) {
      min[r] = Math.min(min[r]!, p[r]!);
      max[r] = Math.max(max[r]!, p[r]!);
    }
  }
  return { min, max };
}

/**
 * The active calibration of a twin's `calibration` property (`{active: true, scale, rotation, translation,
 * ...}`), checked like calibration.json; null when none is active. Throws CalibrationError when the value
 * claims to be active but is not a calibration.
 */
export function activeCalibration(property: unknown): SimilarityTransform | null {
  if (typeof property !== "object" || property === null || (property as { active?: unknown }).active !== true) return null;
  return checkCalibration(property);
}

/**
 * Maps between the virtual (simulation) frame and the real frame of the physical robot:
 *
 *     x_real = s · R · x_virtual + t          q_real = q(R) ⊗ q_virtual
 *     x_virtual = Rᵀ · (x_real − t) / s       q_virtual = q(R)* ⊗ q_real
 *
 * Without a calibration (null) both frames coincide. Positions in metres, quaternions {x, y, z, w}.
 */
export class FrameMap {
  readonly transform: SimilarityTransform | null;
  private readonly qR: Quaternion;

  constructor(transform: SimilarityTransform | null) {
    this.transform = transform;
    this.qR = transform ? matToQuat(transform.rotation) : { x: 0, y: 0, z: 0, w: 1 };
  }

  pointToReal(v: Vec3): Vec3 {
    return this.transform ? applyCalibration(this.transform, v) : ([...v] as Vec3);
  }

  pointToVirtual(p: Vec3): Vec3 {
    return this.transform ? invertCalibration(this.transform, p) : ([...p] as Vec3);
  }

  quatToReal(q: Quaternion): Quaternion {
    return this.transform ? quatMul(this.qR, q) : { ...q };
  }

  quatToVirtual(q: Quaternion): Quaternion {
    return this.transform ? quatMul(quatConj(this.qR), q) : { ...q };
  }

  /** Axis-aligned bounds of a virtual-frame box seen in the real frame (the 8 corners mapped). */
  boundsToReal(b: Bounds): Bounds {
    return this.transform ? transformBounds(b, this.transform) : b;
  }
}
