/**
 * The reachability map (`reachability.csv` + `workspace.json`'s voxel side) as a heat map: one square
 * per voxel reached collision-free, sized like the voxel, coloured by its reachability index (share of
 * the 64 approach directions reached there) from dark blue (few) through green to yellow (many) —
 * the viridis scale, readable by colour-blind users. Hidden until its layer toggle is switched on.
 */
import { BufferGeometry, Float32BufferAttribute, Points, PointsMaterial } from "three";
import { ReachabilityMap, reachabilityVoxel } from "@robwot/core/browser";

/** viridis at 0, 0.25, 0.5, 0.75, 1 */
const STOPS = [
  [0.267, 0.005, 0.329],
  [0.231, 0.322, 0.545],
  [0.129, 0.569, 0.549],
  [0.369, 0.788, 0.384],
  [0.993, 0.906, 0.144],
] as const;

export function heatColour(t: number): [number, number, number] {
  const x = Math.min(1, Math.max(0, t)) * (STOPS.length - 1);
  const i = Math.min(STOPS.length - 2, Math.floor(x));
  const f = x - i;
  const a = STOPS[i]!;
  const b = STOPS[i + 1]!;
  return [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2])];
}

export interface HeatMap {
  points: Points;
  /** voxels in the file / drawn (those with a collision-free sample) */
  voxels: number;
  shown: number;
  maxIndex: number;
}

/** Parses the map (core's checks: file, line, reason) and builds the heat map, colours scaled to the largest index. */
export function buildHeatMap(csv: string, summaryJson: string, source: { csv: string; summary: string }): HeatMap {
  const map = ReachabilityMap.fromCsv(csv, reachabilityVoxel(summaryJson, source.summary), { file: source.csv });
  const reached = map.voxels.filter((v) => v.free > 0);
  const maxIndex = reached.reduce((m, v) => Math.max(m, v.index), 0);
  const positions = new Float32Array(reached.length * 3);
  const colours = new Float32Array(reached.length * 3);
  reached.forEach((v, i) => {
    positions.set(v.centre, 3 * i);
    colours.set(heatColour(maxIndex > 0 ? v.index / maxIndex : 0), 3 * i);
  });
  const geometry = new BufferGeometry();
  geometry.setAttribute("position", new Float32BufferAttribute(positions, 3));
  geometry.setAttribute("color", new Float32BufferAttribute(colours, 3));
  const points = new Points(geometry, new PointsMaterial({ size: 0.8 * map.voxel, vertexColors: true, sizeAttenuation: true, transparent: true, opacity: 0.55, depthWrite: false }));
  points.name = "reachability map";
  return { points, voxels: map.voxels.length, shown: reached.length, maxIndex };
}
