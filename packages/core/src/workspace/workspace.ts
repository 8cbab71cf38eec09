/** A loaded workspace (surface + labelled point cloud) answering "is this target plausible?". Pure. */
import { parseWorkspaceCsv, type WorkspaceCloud } from "./csv.js";
import { WorkspaceMesh } from "./mesh.js";
import { PointCloudIndex, type PointCloudCheck } from "./point-cloud.js";
import type { ReachabilityCheck, ReachabilityMap } from "./reachability.js";

export interface WorkspacePointCheck {
  /** insideWorkspace && pointCloud.ok */
  ok: boolean;
  /** inside workspace.stl */
  insideWorkspace: boolean;
  pointCloud: PointCloudCheck;
  /** the target's voxel in the reachability map, when the twin has one (evidence, not part of ok) */
  reachability?: ReachabilityCheck;
}

export class Workspace {
  readonly cloudIndex: PointCloudIndex;

  constructor(
    readonly mesh: WorkspaceMesh,
    readonly cloud: WorkspaceCloud,
    readonly reachability?: ReachabilityMap,
  ) {
    this.cloudIndex = new PointCloudIndex(cloud.points, cloud.collisionFree);
  }

  /** Builds from the bytes of workspace.stl and the text of workspace.csv (names used in errors). */
  static fromData(stl: ArrayBufferLike | ArrayBufferView, csv: string, names: { stl?: string; csv?: string } = {}, reachability?: ReachabilityMap): Workspace {
    const mesh = WorkspaceMesh.fromStl(stl, names.stl === undefined ? {} : { file: names.stl });
    return new Workspace(mesh, parseWorkspaceCsv(csv, names.csv === undefined ? {} : { file: names.csv }), reachability);
  }

  contains(p: readonly number[]): boolean {
    return this.mesh.contains(p);
  }

  check(p: readonly number[], options: { k?: number; maxGap?: number } = {}): WorkspacePointCheck {
    const insideWorkspace = this.mesh.contains(p);
    const pointCloud = this.cloudIndex.check(p, options);
    return { ok: insideWorkspace && pointCloud.ok, insideWorkspace, pointCloud, ...(this.reachability ? { reachability: this.reachability.check(p) } : {}) };
  }
}
