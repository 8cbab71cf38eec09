/**
 * Calibration frames. The simulation works in the twin's *virtual* world frame; consumers speak the
 * *real* frame of the physical robot when a calibration is active (paper eq. 1):
 *
 *     x_real = s · R · x_virtual + t          q_real = q(R) ⊗ q_virtual
 *     x_virtual = Rᵀ · (x_real − t) / s       q_virtual = q(R)* ⊗ q_real
 *
 * Without a calibration both frames coincide. Positions in metres, quaternions {x, y, z, w}.
 */
import { applyCalibration, invertCalibration, transformBounds, type Bounds, type CalibrationFile, type Quaternion, type Vec3, type Xyz } from "@robwot/core";

export type Mat3 = [Vec3, Vec3, Vec3];

export interface Transform {
  scale: number;
  rotation: Mat3;
  translation: Vec3;
}

export function toTransform(cal: Pick<CalibrationFile, "scale" | "rotation" | "translation">): Transform {
  const r = cal.rotation;
  const row = (i: number): Vec3 => [r[i]?.[0] ?? 0, r[i]?.[1] ?? 0, r[i]?.[2] ?? 0];
  return { scale: cal.scale, rotation: [row(0), row(1), row(2)], translation: [...cal.translation] as Vec3 };
}

/** Rotation matrix -> unit quaternion (Shepperd's method). */
export function matToQuat(m: Mat3): Quaternion {
  const tr = m[0][0] + m[1][1] + m[2][2];
  let x: number, y: number, z: number, w: number;
  if (tr > 0) {
    const s = Math.sqrt(tr + 1) * 2;
    w = s / 4;
    x = (m[2][1] - m[1][2]) / s;
    y = (m[0][2] - m[2][0]) / s;
    z = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const s = Math.sqrt(1 + m[0][0] - m[1][1] - m[2][2]) * 2;
    w = (m[2][1] - m[1][2]) / s;
    x = s / 4;
    y = (m[0][1] + m[1][0]) / s;
    z = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] > m[2][2]) {
    const s = Math.sqrt(1 + m[1][1] - m[0][0] - m[2][2]) * 2;
    w = (m[0][2] - m[2][0]) / s;
    x = (m[0][1] + m[1][0]) / s;
    y = s / 4;
    z = (m[1][2] + m[2][1]) / s;
  } else {
    const s = Math.sqrt(1 + m[2][2] - m[0][0] - m[1][1]) * 2;
    w = (m[1][0] - m[0][1]) / s;
    x = (m[0][2] + m[2][0]) / s;
    y = (m[1][2] + m[2][1]) / s;
    z = s / 4;
  }
  const n = Math.hypot(x, y, z, w);
  return { x: x / n, y: y / n, z: z / n, w: w / n };
}

export function quatMul(a: Quaternion, b: Quaternion): Quaternion {
  return {
    w: a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
    x: a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
    y: a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
    z: a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
  };
}

const conj = (q: Quaternion): Quaternion => ({ x: -q.x, y: -q.y, z: -q.z, w: q.w });

export const vec = (p: Xyz): Vec3 => [p.x, p.y, p.z];
export const xyz = (v: readonly number[]): Xyz => ({ x: v[0] ?? 0, y: v[1] ?? 0, z: v[2] ?? 0 });
export const quat = (q: readonly number[]): Quaternion => ({ x: q[0] ?? 0, y: q[1] ?? 0, z: q[2] ?? 0, w: q[3] ?? 1 });
export const quatArr = (q: Quaternion): [number, number, number, number] => [q.x, q.y, q.z, q.w];

/** Maps between the virtual (simulation) frame and the real frame; identity without calibration. */
export class FrameMap {
  readonly transform: Transform | null;
  private readonly qR: Quaternion;

  constructor(transform: Transform | null) {
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
    return this.transform ? quatMul(conj(this.qR), q) : { ...q };
  }

  /** Axis-aligned bounds of a virtual-frame box seen in the real frame (the 8 corners mapped). */
  boundsToReal(b: Bounds): Bounds {
    return this.transform ? transformBounds(b, this.transform) : b;
  }
}
