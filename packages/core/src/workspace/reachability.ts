/**
 * `reachability.csv`, the reachability map (README "Reachability map"): header
 * `x,y,z,samples,free,directions,index`, one row per voxel holding a sample; x, y, z the voxel centre
 * (m, world frame), voxels of side `voxel` aligned to the origin (voxel i spans [i·voxel, (i+1)·voxel) on
 * each axis); `free` of the `samples` configurations ending in the voxel are collision-free; `directions`
 * of the 64 approach directions (the end link's z axis) are reached collision-free; index =
 * directions / 64. The side is workspace.json's `reachability.voxel`. Pure (browser-safe).
 */
import { CsvError, InvalidArgumentError } from "../errors.js";
import { TWIN_FILES } from "../twin-layout.js";
import { parseNumericCsv } from "./csv.js";

const HEADER = ["x", "y", "z", "samples", "free", "directions", "index"] as const;

export interface ReachabilityVoxel {
  /** voxel centre, m */
  centre: [number, number, number];
  samples: number;
  free: number;
  directions: number;
  /** directions / 64, in [0, 1] */
  index: number;
}

export interface ReachabilityCheck {
  /** a collision-free sample ends in the target's voxel */
  ok: boolean;
  /** the voxel's reachability index (0 when no sample ends there) */
  index: number;
  samples: number;
  free: number;
  /** voxel side, m */
  voxel: number;
}

const key = (i: number, j: number, k: number): string => `${i},${j},${k}`;

export class ReachabilityMap {
  private readonly cells = new Map<string, ReachabilityVoxel>();

  constructor(
    /** voxel side, m */
    readonly voxel: number,
    readonly voxels: readonly ReachabilityVoxel[],
  ) {
    if (!(Number.isFinite(voxel) && voxel > 0)) throw new InvalidArgumentError(`voxel side must be a positive number of metres, got ${voxel}`, { param: "voxel", got: voxel });
    for (const v of voxels) this.cells.set(this.keyOf(v.centre), v);
  }

  /** Parses the file's text; `voxel` from workspace.json. Every row is checked (file, line, reason). */
  static fromCsv(text: string, voxel: number, options: { file?: string } = {}): ReachabilityMap {
    const file = options.file ?? TWIN_FILES.reachability;
    const { rows, values } = parseNumericCsv(text, file, HEADER);
    const voxels: ReachabilityVoxel[] = [];
    for (let r = 0; r < rows; r++) {
      const [x, y, z, samples, free, directions, index] = Array.from(values.subarray(7 * r, 7 * r + 7));
      const line = r + 2;
      const bad = (why: string): never => {
        throw new CsvError(`${file}:${line}: ${why}`, { file, line });
      };
      for (const c of [x!, y!, z!]) if (Math.abs(c / voxel - 0.5 - Math.round(c / voxel - 0.5)) > 1e-3) bad(`${c} is not a voxel centre of a ${voxel} m grid (${TWIN_FILES.summary} reachability.voxel)`);
      if (!(Number.isInteger(samples) && samples! >= 1)) bad(`samples is ${samples}, expected an integer >= 1`);
      if (!(Number.isInteger(free) && free! >= 0 && free! <= samples!)) bad(`free is ${free}, expected an integer within 0..samples (${samples})`);
      if (!(Number.isInteger(directions) && directions! >= 0 && directions! <= Math.min(64, free!))) bad(`directions is ${directions}, expected an integer within 0..min(64, free)`);
      if (Math.abs(index! - directions! / 64) > 1e-6) bad(`index is ${index}, expected directions / 64 = ${directions! / 64}`);
      voxels.push({ centre: [x!, y!, z!], samples: samples!, free: free!, directions: directions!, index: index! });
    }
    return new ReachabilityMap(voxel, voxels);
  }

  private keyOf(p: readonly number[]): string {
    return key(Math.floor(p[0]! / this.voxel), Math.floor(p[1]! / this.voxel), Math.floor(p[2]! / this.voxel));
  }

  /** The voxel holding `p` (m, world frame), if any sample ended there. */
  at(p: readonly number[]): ReachabilityVoxel | undefined {
    return this.cells.get(this.keyOf(p));
  }

  check(p: readonly number[]): ReachabilityCheck {
    const v = this.at(p);
    return { ok: (v?.free ?? 0) > 0, index: v?.index ?? 0, samples: v?.samples ?? 0, free: v?.free ?? 0, voxel: this.voxel };
  }
}
