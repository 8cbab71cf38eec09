/**
 * Read-only debug state exposed as `window.__robwot` for tests and curious users. The page writes it;
 * nothing reads it back, so tampering with it from the console changes nothing.
 */
import type { DivergenceHistory } from "./divergence-plot.js";
import type { ObjectHistory } from "./objects-plot.js";
import type { ProgramDrawn } from "./program-panel.js";

export interface DebugState {
  /** "loading" until the TD, model and data are loaded, then "ready" (or "error" if the model failed). */
  phase: "loading" | "ready" | "error" | "list";
  thing: string | null;
  /** Joint values (rad or m) currently applied to the displayed model. */
  joints: Record<string, number>;
  /** Number of joint frames applied to the model (display-rate updates). */
  framesApplied: number;
  /** End-effector link position of the displayed model, URDF world frame (m), for cross-checks. */
  ee: { x: number; y: number; z: number } | null;
  /** The Cartesian target marked in the view (virtual/world frame) and its verdict (null: not validated). */
  target: { position: [number, number, number]; valid: boolean | null } | null;
  liveConnected: boolean;
  liveMessages: number;
  lastStatus: unknown;
  collisions: number;
  /** Bodies (link or obstacle names) shown red right now after a collision event. */
  highlighted: string[];
  pointCloud: { shown: number; total: number; collisionFree: number } | null;
  workspaceTriangles: number;
  /** reachability.csv: voxels in the file, drawn (reached collision-free), largest index, layer shown */
  reachability: { voxels: number; shown: number; maxIndex: number; visible: boolean } | null;
  obstacles: string[];
  /** The world's objects as drawn: position (URDF world, m) by name. */
  objects: Record<string, number[]>;
  /** Robots of the other twins sharing this world: base position (URDF world, m) and joints shown. */
  otherRobots: Record<string, { base: number[]; joints: Record<string, number> }>;
  /** The physical robot the twin follows (`/live` `physical`): its joints, the reading's age (s), whether it
   *  is drawn and the simulated robot shown as a ghost; null when the twin follows nothing. */
  physical: { joints: Record<string, number>; age: number | null; drawn: boolean; ghost: boolean } | null;
  /** The program drawn by the program panel (TCP points per passed step, the refused step) and plotted (joint
   *  positions and velocities, TCP speed over time), null before one. */
  program: ProgramDrawn | null;
  /** The objects over time plotted from /live `scene` messages (`objects-plot.ts`), null before one. */
  objectHistory: ObjectHistory | null;
  /** The physical robot's divergence over time from /live `physical` messages and `divergence` events
   *  (`divergence-plot.ts`), null while the twin follows nothing. */
  divergenceHistory: DivergenceHistory | null;
  errors: string[];
  twins: string[];
}

export const debugState: DebugState = {
  phase: "loading",
  thing: null,
  joints: {},
  framesApplied: 0,
  ee: null,
  target: null,
  liveConnected: false,
  liveMessages: 0,
  lastStatus: null,
  collisions: 0,
  highlighted: [],
  pointCloud: null,
  workspaceTriangles: 0,
  reachability: null,
  obstacles: [],
  objects: {},
  otherRobots: {},
  physical: null,
  program: null,
  objectHistory: null,
  divergenceHistory: null,
  errors: [],
  twins: [],
};

declare global {
  interface Window {
    __robwot: Readonly<DebugState>;
  }
}

/** Publish a deep-frozen snapshot; call after each change worth observing. */
export function publishDebug(): void {
  window.__robwot = Object.freeze(structuredClone(debugState));
}
