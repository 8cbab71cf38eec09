/**
 * The obstacle layer: obstacles and objects (in their colours, where they rest), built from scene.json at
 * load, rebuilt from every /live `scene` message (the shared world's obstacles and objects after a run-time
 * add/move/remove, Contract 4). The newest scene always wins: a
 * slower, older build is discarded, and scene.json never replaces a scene that came live.
 */
import { Group, Mesh } from "three";
import { TWIN_FILES } from "@robwot/core/browser";
import { debugState, publishDebug } from "./debug.js";
import { showError } from "./errors.js";
import type { MotionPanel } from "./motion-panel.js";
import { buildObstacles } from "./obstacles.js";
import type { Stage } from "./stage.js";

export class ObstacleLayer {
  private group: Group | null = null;
  private visible = true;
  private requested = 0;
  private shown = 0;
  private liveSeen = false;
  /** Obstacle errors already shown (a rebuild must not repeat them). */
  private readonly reported = new Set<string>();

  constructor(
    private readonly stage: Stage,
    motion: MotionPanel,
    /** base URL relative mesh files resolve against (the twin folder) */
    private readonly base: string,
  ) {
    motion.addLayer("obstacles", true, (v) => {
      this.visible = v;
      if (this.group) stage.setVisible(this.group, v);
    });
  }

  /** A scene document (`{obstacles: [...], objects: [...]}`) from scene.json (`live` false) or a /live message. */
  async show(scene: unknown, live: boolean): Promise<void> {
    if (live) this.liveSeen = true;
    else if (this.liveSeen) return;
    const generation = ++this.requested;
    const built = await buildObstacles(scene, this.base);
    if (generation < this.shown || (!live && this.liveSeen)) {
      dispose(built.group);
      return;
    }
    this.shown = generation;
    for (const e of built.errors) {
      if (this.reported.has(e.message)) continue;
      this.reported.add(e.message);
      showError(live ? "scene (live)" : TWIN_FILES.scene, e);
    }
    if (this.group) {
      this.group.removeFromParent();
      dispose(this.group);
    }
    this.group = built.group;
    this.stage.add(built.group);
    this.stage.setVisible(built.group, this.visible);
    this.stage.invalidate();
    debugState.obstacles = built.names;
    debugState.objects = built.objects;
    publishDebug();
  }
}

function dispose(group: Group): void {
  group.traverse((o) => {
    if (!(o instanceof Mesh)) return;
    o.geometry.dispose();
    const m = o.material as { dispose?: () => void } | { dispose?: () => void }[];
    for (const x of Array.isArray(m) ? m : [m]) x.dispose?.();
  });
}
