/**
 * Progress of a robot's first load (`robot.loadProgress`): what happens, where the convex parts go (the
 * collision cache folder the backend writes to), then one step per collision mesh with the backend's
 * estimate of the time left.
 */
import type { RobotLoadProgressNotification } from "@robwot/sim-client";
import { formatDuration, type ProgressSink } from "./progress.js";

/** A load that takes longer than this without a mesh reported is (nearly always) the first decomposition
 * of the meshes of a scene's other robots, which report no progress. */
export const SLOW_LOAD_MS = 10_000;
const CACHED_WHERE =
  "cached in $ROBWOT_COLLISION_CACHE, else $XDG_CACHE_HOME/robwot/collision or ~/.cache/robwot/collision, and in the twin folder";
export const SLOW_LOAD = `still loading: the first time a robot is used, its concave collision meshes are split into convex parts (${CACHED_WHERE})`;

/** The load's progress lines; `seen` tells whether any mesh was reported. */
export function meshProgress(progress: ProgressSink): { onMesh: (m: RobotLoadProgressNotification) => void; seen: () => boolean } {
  let seen = false;
  return {
    seen: () => seen,
    onMesh(m) {
      seen = true;
      if (m.done === 0) {
        progress.info(`first use of this robot: its ${m.total} new collision mesh(es) are split into convex parts where concave, cached in ${m.cache} (and in the twin folder)`);
        progress.stage("decompose");
        return;
      }
      const what = m.parts === 0 ? "convex, kept" : `${m.parts} convex parts`;
      progress.step("decompose", m.done, m.total, `${m.mesh} (${what}, ${formatDuration(m.seconds)})`, m.eta);
    },
  };
}
