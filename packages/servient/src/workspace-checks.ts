/**
 * The twin's workspace checks, with the same core code any consumer runs offline on the linked files:
 * inside workspace.stl, a collision-free sample of workspace.csv near the target, and the target's voxel
 * in reachability.csv (its index). Virtual frame.
 */
import { existsSync } from "node:fs";
import { join } from "node:path";
import { loadWorkspace, type ReachabilityCheck, TWIN_FILES, type Vec3, type Workspace } from "@robwot/core";
import { servientError } from "./errors.js";

export interface WorkspaceChecks {
  inside(p: Vec3): boolean;
  score(p: Vec3): { score: number; k: number; nearestFree: number; maxGap: number; ok: boolean };
  /** the target's voxel of reachability.csv; undefined for a twin folder without one */
  reach(p: Vec3): ReachabilityCheck | undefined;
}

export function workspaceChecks(ws: Workspace): WorkspaceChecks {
  return {
    inside: (p) => ws.contains(p),
    score: (p) => {
      const c = ws.cloudIndex.check(p);
      // a position with no collision-free sample at all reports -1 m (JSON has no Infinity)
      return { score: c.share, k: c.k, nearestFree: Number.isFinite(c.nearestFree) ? c.nearestFree : -1, maxGap: c.maxGap, ok: c.ok };
    },
    reach: (p) => ws.reachability?.check(p),
  };
}

/**
 * Loads workspace.stl + workspace.csv of a twin folder. A folder without them, with files that do not
 * load, or whose workspace.csv has no collision-free point (generate never writes one) is refused naming
 * them: serving it with the Cartesian checks silently off or degenerate would report on evidence that
 * is not there.
 */
export async function loadWorkspaceChecks(dir: string): Promise<WorkspaceChecks> {
  const missing = [TWIN_FILES.surface, TWIN_FILES.pointCloud].filter((f) => !existsSync(join(dir, f)));
  if (missing.length > 0) {
    throw servientError("E_TWIN_FOLDER", `twin folder ${dir} has no ${missing.join(" and ")} (the Cartesian checks need them): regenerate it with robwot generate`, {
      folder: dir,
      missing,
    });
  }
  let ws: Workspace;
  try {
    ws = await loadWorkspace(dir);
  } catch (err) {
    throw servientError("E_TWIN_FOLDER", `twin folder ${dir}: its workspace files do not load: ${(err as Error).message} (regenerate it with robwot generate)`, { folder: dir });
  }
  if (!ws.cloud.collisionFree.includes(1)) {
    throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.pointCloud)} has no collision-free point: the workspace is empty (regenerate it with robwot generate)`, {
      folder: dir,
      file: TWIN_FILES.pointCloud,
    });
  }
  return workspaceChecks(ws);
}
