/**
 * What `robwot generate` says of a labelled workspace before writing the twin: one without a surface (no
 * collision-free sample, or only a point or a line of end-effector positions) is refused, naming what
 * touches; a surface that is not the samples' alpha shape is noted.
 */
import { readFileSync, statSync } from "node:fs";
import { join } from "node:path";
import { mulberry32, TWIN_FILES } from "@robwot/core";
import type { RobotModel, SimClient, WorkspaceSummary } from "@robwot/sim-client";
import { CliError } from "./errors.js";
import type { ProgressSink } from "./progress.js";

/** Configurations checked again, one by one, to name what touches when no sample was collision-free. */
const WHY_SAMPLES = 40;

/**
 * What touches in an all-colliding workspace: seeded random configurations within the joint limits checked
 * one by one, their contacts counted per pair of bodies (robot links, obstacles, other robots), the most
 * frequent first with the share of configurations it appears in.
 */
async function touchingPairs(sim: SimClient, model: RobotModel, seed: number): Promise<string> {
  const random = mulberry32(seed);
  const joints = model.controllable.map((n) => model.joints.find((j) => j.name === n)!);
  const counts = new Map<string, number>();
  for (let i = 0; i < WHY_SAMPLES; i++) {
    const q = joints.map((j) => j.lower + random() * (j.upper - j.lower));
    const report = await sim.checkCollision({ robot: model.id, positions: q });
    const pairs = new Set(report.contacts.map((c) => [c.a, c.b].map((s) => (s.link === null ? s.body : `${s.body}/${s.link}`)).sort().join(" touches ")));
    for (const p of pairs) counts.set(p, (counts.get(p) ?? 0) + 1);
  }
  const top = [...counts].sort((a, b) => b[1] - a[1]).slice(0, 4);
  if (top.length === 0) return `${WHY_SAMPLES} configurations checked again showed no contact`;
  return `in ${WHY_SAMPLES} configurations checked again: ${top.map(([p, n]) => `${p} (${Math.round((100 * n) / WHY_SAMPLES)} %)`).join(", ")}`;
}

/**
 * A twin whose collision-free workspace has no surface (no collision-free sample, or only a point or a
 * line of end-effector positions) could never validate a Cartesian target, and serve would refuse it:
 * it is not written. Exit 1 with what to check.
 */
export async function refuseDegenerate(summary: WorkspaceSummary, dir: string, sim: SimClient, model: RobotModel, crowded: readonly string[]): Promise<void> {
  if (summary.collisionFree === 0) {
    const touching = await touchingPairs(sim, model, summary.seed);
    const why = crowded.length > 0 ? `; ${crowded.join("; ")}` : "";
    throw new CliError(
      `no collision-free configuration in ${summary.samples} samples: the robot touches itself or the scene everywhere; ${touching}${why} (check the scene, the base pose and the URDF's collision geometry)`,
      "E_WORKSPACE",
      1,
    );
  }
  const triangles = statSync(join(dir, TWIN_FILES.surface)).size > 84 ? readFileSync(join(dir, TWIN_FILES.surface)).readUInt32LE(80) : 0;
  if (triangles === 0) {
    throw new CliError(
      `the collision-free workspace is degenerate (no surface through the collision-free points): the end effector reaches a single point only; check --ee (the end-effector link) and the joint limits`,
      "E_WORKSPACE",
      1,
    );
  }
}

/** What the user should know about a workspace surface that is not the alpha shape of the samples. */
export function noteSurface(summary: WorkspaceSummary, progress: ProgressSink): void {
  if (summary.method === "convex-hull") {
    progress.info("the alpha shape degenerated (too few points): workspace.stl is the convex hull");
  } else if (summary.halfThickness !== undefined) {
    progress.info(`flat workspace (${summary.method}): workspace.stl is the reachable region thickened by ${summary.halfThickness * 1000} mm on each side`);
  }
}
