/**
 * Offline workspace checks ("validation without the twin"): the consumer downloads the twin's
 * `workspace.stl` and `workspace.csv` from the TD's links once, then answers "inside the workspace
 * surface?" and the k-nearest-neighbour point-cloud score locally with @robwot/core (no Python,
 * no request to the twin per target); with the reachability map (`reachability.csv`) when the TD links
 * one, the target voxel's reachability index too.
 */
import { loadWorkspaceFromUrls, REACHABILITY_REL, type PointCloudCheck, type ReachabilityCheck } from "@robwot/core";
import { authHeaders, type Twin } from "./connect.js";
import { linkUrl } from "@robwot/core";
import type { Vec3 } from "@robwot/core";

export interface OfflineVerdict {
  inside: boolean;
  /** unsigned distance to the workspace surface (m) */
  surfaceDistance: number;
  pointCloud: PointCloudCheck;
  /** the target's voxel of reachability.csv (evidence, not part of ok); absent without a map */
  reachability?: ReachabilityCheck;
  ok: boolean;
}

export interface OfflineWorkspace {
  stlUrl: string;
  csvUrl: string;
  triangles: number;
  points: number;
  check(p: Vec3): OfflineVerdict;
}

export async function loadOfflineWorkspace(twin: Twin, options: { k?: number; maxGap?: number } = {}): Promise<OfflineWorkspace> {
  const stlUrl = linkUrl(twin.td, "workspace", twin.url);
  const csvUrl = linkUrl(twin.td, "workspace-pointcloud", twin.url);
  const headers = authHeaders(twin.auth);
  const hasMap = twin.td.links?.some((l) => l.rel === REACHABILITY_REL) ?? false;
  const reach = hasMap ? { csvUrl: linkUrl(twin.td, REACHABILITY_REL, twin.url), summaryUrl: linkUrl(twin.td, "workspace-summary", twin.url) } : undefined;
  const ws = await loadWorkspaceFromUrls(stlUrl, csvUrl, (url) => fetch(url, { headers }), reach);
  return {
    stlUrl,
    csvUrl,
    triangles: ws.mesh.triangleCount,
    points: ws.cloudIndex.size,
    check(p: Vec3): OfflineVerdict {
      const { insideWorkspace, pointCloud, reachability, ok } = ws.check(p, options);
      return { inside: insideWorkspace, surfaceDistance: ws.mesh.distanceToSurface(p), pointCloud, ...(reachability ? { reachability } : {}), ok };
    },
  };
}
