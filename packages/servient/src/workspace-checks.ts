/**
 * The twin's workspace checks, with the same core code any consumer runs offline on the linked files:
 * inside workspace.stl, and the k-nearest-neighbour point-cloud score of workspace.csv. Virtual frame.
 */
import { existsSync } from "node:fs";
import { join } from "node:path";
import { loadWorkspace, type Vec3, type Workspace } from "@robwot/core";

export interface WorkspaceChecks {
  inside(p: Vec3): boolean;
  score(p: Vec3): { score: number; threshold: number; k: number; ok: boolean; nearestDistance: number };
}

export function workspaceChecks(ws: Workspace): WorkspaceChecks {
  return {
    inside: (p) => ws.contains(p),
    score: (p) => {
      const c = ws.cloudIndex.check(p);
      return { score: c.share, threshold: c.threshold, k: c.k, ok: c.ok, nearestDistance: c.nearestDistance };
    },
  };
}

/** Loads workspace.stl + workspace.csv of a twin folder; null when the folder has none. */
export async function loadWorkspaceChecks(dir: string): Promise<WorkspaceChecks | null> {
  if (!existsSync(join(dir, "workspace.stl")) || !existsSync(join(dir, "workspace.csv"))) return null;
  return workspaceChecks(await loadWorkspace(dir));
}
