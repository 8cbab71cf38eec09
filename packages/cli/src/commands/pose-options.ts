/** `robwot generate`'s poses and tool shapes from the command line: `--base`, `--tcp`, `--tool-box`, `--tool-cylinder`. */
import { quatArr, quatMul } from "@robwot/core/geometry";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { CliError } from "../errors.js";

const { Position, Rpy, ToolOffset, ToolSize } = VALUE_SCHEMAS;

/** A robot base pose: position (m) and orientation quaternion [x, y, z, w] in the world frame. */
export interface BasePose {
  position: [number, number, number];
  orientation: [number, number, number, number];
}

export type ToolShape = { type: "box"; size: [number, number, number] } | { type: "cylinder"; radius: number; length: number };

/** `X,Y,Z[,ROLL,PITCH,YAW]` of `--option` as six numbers (the angles 0 when left out). */
function pose(option: string, value: string): [number, number, number, number, number, number] {
  const parts = value.split(",").map((p) => p.trim());
  const nums = parts.map(Number);
  if ((parts.length !== 3 && parts.length !== 6) || parts.some((p) => p === "") || nums.some((n) => !Number.isFinite(n))) {
    throw new CliError(`--${option} must be X,Y,Z or X,Y,Z,ROLL,PITCH,YAW (metres, radians), got "${value}"`);
  }
  const [x, y, z, roll = 0, pitch = 0, yaw = 0] = nums as [number, number, number, number?, number?, number?];
  return [x, y, z, roll, pitch, yaw];
}

/**
 * `--base X,Y,Z[,ROLL,PITCH,YAW]`: metres and radians, the angles fixed-axis roll-pitch-yaw as a URDF
 * `<origin rpy>` (rotate about world X by roll, then world Y by pitch, then world Z by yaw), so
 * q = qz(yaw) ⊗ qy(pitch) ⊗ qx(roll). Ranges are the backend contract's Position and Rpy.
 */
export function parseBase(value: string | undefined): BasePose | undefined {
  if (value === undefined) return undefined;
  const [x, y, z, roll, pitch, yaw] = pose("base", value);
  const pmax = Position.items.maximum;
  if ([x, y, z].some((v) => Math.abs(v) > pmax)) throw new CliError(`--base: X, Y and Z must be within ±${pmax} m, got "${value}"`);
  const amax = Rpy.items.maximum;
  if ([roll, pitch, yaw].some((v) => Math.abs(v) > amax)) throw new CliError(`--base: ROLL, PITCH and YAW must be within ±${amax} rad, got "${value}"`);
  const axis = (a: number, i: 0 | 1 | 2) => {
    const v = [0, 0, 0];
    v[i] = Math.sin(a / 2);
    return { x: v[0] as number, y: v[1] as number, z: v[2] as number, w: Math.cos(a / 2) };
  };
  const q = quatMul(axis(yaw, 2), quatMul(axis(pitch, 1), axis(roll, 0)));
  return { position: [x, y, z], orientation: quatArr(q) };
}

/** `--tcp X,Y,Z[,ROLL,PITCH,YAW]`: metres and radians in the end-effector link's frame, as a URDF `<origin>`. */
export function parseTcp(value: string | undefined): number[] | undefined {
  if (value === undefined) return undefined;
  const nums = pose("tcp", value);
  const { minimum, maximum } = ToolOffset.items;
  if (nums.some((v) => v < minimum || v > maximum)) throw new CliError(`--tcp: every value must be within [${minimum}, ${maximum}], got "${value}"`);
  return nums;
}

/** `--tool-box SX,SY,SZ` or `--tool-cylinder RADIUS,LENGTH` (metres, each in (0, 10]); not both. */
export function parseToolShape(box: string | undefined, cylinder: string | undefined): ToolShape | undefined {
  if (box !== undefined && cylinder !== undefined) throw new CliError("give --tool-box or --tool-cylinder, not both");
  const nums = (option: string, value: string, count: number, what: string): number[] => {
    const parts = value.split(",").map((p) => Number(p.trim()));
    if (parts.length !== count || parts.some((v) => !Number.isFinite(v) || v <= ToolSize.exclusiveMinimum || v > ToolSize.maximum)) {
      throw new CliError(`--${option} must be ${what} (metres, each in (${ToolSize.exclusiveMinimum}, ${ToolSize.maximum}]), got "${value}"`);
    }
    return parts;
  };
  if (box !== undefined) {
    const [x, y, z] = nums("tool-box", box, 3, "SX,SY,SZ") as [number, number, number];
    return { type: "box", size: [x, y, z] };
  }
  if (cylinder !== undefined) {
    const [radius, length] = nums("tool-cylinder", cylinder, 2, "RADIUS,LENGTH") as [number, number];
    return { type: "cylinder", radius, length };
  }
  return undefined;
}
