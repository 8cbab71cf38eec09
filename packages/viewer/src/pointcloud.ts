/**
 * The workspace point cloud (`workspace.csv`: x,y,z,collision_free[,joint...], metres, world frame):
 * collision-free points blue, colliding points red, like the original's figures. Large clouds are
 * subsampled (seeded random draw, both classes kept in proportion) to keep the page fluid.
 */
import { BufferGeometry, Float32BufferAttribute, Points, PointsMaterial } from "three";
import { mulberry32, parseWorkspaceCsv as parseCloud, TWIN_FILES } from "@robwot/core/browser";

export const FREE_COLOUR = [0.16, 0.45, 0.85] as const;
export const COLLIDING_COLOUR = [0.86, 0.2, 0.16] as const;
export const MAX_POINTS = 60_000;

export interface ParsedCloud {
  /** xyz triples of the kept points. */
  positions: Float32Array;
  free: Uint8Array;
  total: number;
  collisionFree: number;
}

/**
 * Reads workspace.csv with core's parser (line-numbered `CsvError`s) and keeps at most `maxPoints` of it:
 * a seeded Bernoulli draw (core's mulberry32: the same points on every load, no aliasing with periodic
 * row orders), both classes in proportion.
 */
export function parseWorkspaceCsv(text: string, maxPoints = MAX_POINTS, source: string = TWIN_FILES.pointCloud): ParsedCloud {
  const cloud = parseCloud(text, { file: source });
  const total = cloud.collisionFree.length;
  const p = Math.min(1, maxPoints / Math.max(1, total));
  const rand = mulberry32(1);
  const keep = Array.from({ length: total }, () => p >= 1 || rand() < p);
  const kept = keep.reduce((n, k) => n + (k ? 1 : 0), 0);
  const positions = new Float32Array(kept * 3);
  const free = new Uint8Array(kept);
  let collisionFree = 0;
  let k = 0;
  for (let r = 0; r < total; r++) {
    const f = cloud.collisionFree[r] as number;
    collisionFree += f;
    if (!keep[r]) continue;
    positions.set(cloud.points.subarray(3 * r, 3 * r + 3), k * 3);
    free[k] = f;
    k++;
  }
  return { positions, free, total, collisionFree };
}

export function buildPointCloud(cloud: ParsedCloud): Points {
  const n = cloud.free.length;
  const colours = new Float32Array(n * 3);
  for (let i = 0; i < n; i++) colours.set(cloud.free[i] === 1 ? FREE_COLOUR : COLLIDING_COLOUR, i * 3);
  const geometry = new BufferGeometry();
  geometry.setAttribute("position", new Float32BufferAttribute(cloud.positions, 3));
  geometry.setAttribute("color", new Float32BufferAttribute(colours, 3));
  const points = new Points(geometry, new PointsMaterial({ size: 0.012, vertexColors: true, sizeAttenuation: true }));
  points.name = "workspace point cloud";
  return points;
}
