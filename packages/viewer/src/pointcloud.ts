/**
 * The workspace point cloud (`workspace.csv`: x,y,z,collision_free[,joint...], metres, world frame):
 * collision-free points blue, colliding points red, like the original's figures. Large clouds are
 * subsampled (seeded random draw, both classes kept in proportion) to keep the page fluid.
 */
import { BufferGeometry, Float32BufferAttribute, Points, PointsMaterial } from "three";
import { ViewerError } from "./errors.js";

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

export function parseWorkspaceCsv(text: string, maxPoints = MAX_POINTS, source = "workspace.csv"): ParsedCloud {
  const lines = text.split("\n");
  let first = 0;
  const head = lines[0]?.trim() ?? "";
  if (head.length > 0 && !/^[-+\d.]/.test(head)) first = 1; // header row
  const rows: number[] = [];
  for (let i = first; i < lines.length; i++) if ((lines[i] ?? "").trim().length > 0) rows.push(i);
  // Subsample with a seeded pseudo-random Bernoulli draw (no aliasing with periodic row orders, the
  // same points on every load).
  const p = Math.min(1, maxPoints / Math.max(1, rows.length));
  const rand = mulberry32(1);
  const keep = rows.map(() => p >= 1 || rand() < p);
  const kept = keep.reduce((n, k) => n + (k ? 1 : 0), 0);
  const positions = new Float32Array(kept * 3);
  const free = new Uint8Array(kept);
  let collisionFree = 0;
  let k = 0;
  for (let r = 0; r < rows.length; r++) {
    const lineNo = rows[r] as number;
    const cols = (lines[lineNo] as string).split(",");
    const x = Number(cols[0]);
    const y = Number(cols[1]);
    const z = Number(cols[2]);
    const f = Number(cols[3]);
    if (cols.length < 4 || cols.slice(0, 4).some((c) => c.trim() === "") || ![x, y, z].every(Number.isFinite) || (f !== 0 && f !== 1)) {
      throw new ViewerError("E_CSV", `${source} line ${lineNo + 1}: expected x,y,z,collision_free(0|1)`, {
        file: source,
        line: lineNo + 1,
        got: (lines[lineNo] as string).slice(0, 80),
      });
    }
    if (f === 1) collisionFree++;
    if (!keep[r]) continue;
    positions.set([x, y, z], k * 3);
    free[k] = f;
    k++;
  }
  return { positions, free, total: rows.length, collisionFree };
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

/** Small seeded PRNG (mulberry32), uniform in [0, 1). */
function mulberry32(seed: number): () => number {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}
