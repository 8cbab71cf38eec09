/**
 * What a new scan frame changes in the world's scanned obstacles (`scan-source.ts`), as the same
 * `addObstacle` / `moveObstacle` / `removeObstacle` a client would send. Pure: unit-tested.
 *
 * Scanned covers are boxes (an object's box, a support's box, or the boxes of a voxel cover). A frame's
 * box is written grown by `hysteresis` on every side, so that the next frames' boxes of a still object,
 * which differ by the sensor's noise, lie inside it: a box inside an obstacle already there changes
 * nothing (the obstacle still holds every point). One that is not is an obstacle moved (the nearest
 * unmatched one of the same size, within `reach`), else a new one; obstacles no box of the frame falls
 * into are removed. The obstacles stay conservative: each holds the frame's box it was matched to.
 */
import { quatRotate, type Quaternion, type Vec3 } from "@robwot/core";

export interface ScanBox {
  name: string;
  size: Vec3;
  position: Vec3;
  orientation: Quaternion;
}

export interface ScanChanges {
  add: ScanBox[];
  move: { name: string; position: Vec3; orientation: Quaternion }[];
  remove: string[];
}

const conj = (q: Quaternion): Quaternion => ({ x: -q.x, y: -q.y, z: -q.z, w: q.w });
const sub = (a: Vec3, b: Vec3): Vec3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
const add = (a: Vec3, b: Vec3): Vec3 => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];

/** The eight corners of a box, world frame. */
function corners(b: ScanBox): Vec3[] {
  const out: Vec3[] = [];
  for (const sx of [-0.5, 0.5]) for (const sy of [-0.5, 0.5]) for (const sz of [-0.5, 0.5]) {
    out.push(add(b.position, quatRotate(b.orientation, [sx * b.size[0], sy * b.size[1], sz * b.size[2]])));
  }
  return out;
}

/** Whether box `inner` lies inside box `outer` (boxes are convex: their corners do). */
export function contains(outer: ScanBox, inner: ScanBox, tolerance = 1e-9): boolean {
  const back = conj(outer.orientation);
  return corners(inner).every((c) => {
    const local = quatRotate(back, sub(c, outer.position));
    return local.every((v, i) => Math.abs(v) <= outer.size[i]! / 2 + tolerance);
  });
}

/** `box` grown by `margin` on every side. */
export function grown(box: ScanBox, margin: number): ScanBox {
  return { ...box, size: box.size.map((s) => s + 2 * margin) as Vec3 };
}

const distance = (a: Vec3, b: Vec3): number => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

/**
 * The changes turning `current` (the scanned obstacles in the world, as written) into obstacles holding
 * every box of `frame`. New obstacles are named by `newName()`.
 */
export function scanChanges(current: readonly ScanBox[], frame: readonly ScanBox[], hysteresis: number, reach: number, newName: () => string): ScanChanges {
  const kept = new Set<string>();
  const out: ScanChanges = { add: [], move: [], remove: [] };
  const pending: ScanBox[] = [];
  for (const box of frame) {
    const holder = current.find((c) => !kept.has(c.name) && contains(c, box));
    if (holder) kept.add(holder.name);
    else pending.push(box);
  }
  for (const box of pending) {
    const want = grown(box, hysteresis);
    const same = current
      .filter((c) => !kept.has(c.name) && c.size.every((s, i) => s >= box.size[i]! && s <= want.size[i]! + 2 * hysteresis))
      .map((c) => ({ c, d: distance(c.position, box.position) }))
      .filter(({ d }) => d <= reach)
      .sort((a, b) => a.d - b.d)[0];
    if (same) {
      kept.add(same.c.name);
      out.move.push({ name: same.c.name, position: box.position, orientation: box.orientation });
    } else {
      out.add.push({ ...want, name: newName() });
    }
  }
  out.remove = current.filter((c) => !kept.has(c.name)).map((c) => c.name);
  return out;
}
