/**
 * Simulation-in-the-loop validation (the original's key idea): the verdict on a target is the backend's
 * plan (`robot.plan`: joint limits, IK solutions for a pose, a collision-free path from the current
 * state — the same check `robot.move` makes before it moves), plus the static checks on the twin's
 * files (inside workspace.stl, point-cloud score, reachability-map voxel), computed here.
 *
 * Policy: the simulation decides. `valid` is the plan's verdict. The static checks are the evidence a
 * consumer without the twin has; they are reported in `checks` (and, when they disagree with the
 * simulation, in `notes`), but a weaker check never vetoes a stronger one. Nothing here moves the twin.
 */
import { quatArr, type Quaternion, tdContact, TWIN_FILES, type ValidationReport, type Vec3 } from "@robwot/core";
import type { Plan, PlanChecks } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import type { Twin } from "./twin.js";
import type { WorkspaceChecks } from "./workspace-checks.js";

const fmt = (v: number): string => (Math.abs(v) >= 1e-3 || v === 0 ? v.toFixed(4) : v.toExponential(2));

/** A Cartesian target in the twin's (virtual) frame: what the backend plans for. */
export interface PoseTarget {
  position: Vec3;
  orientation?: [number, number, number, number];
  /** "lin"/"circ": the end effector on the straight line or the arc through `via` (the backend's
   * `motion`); absent: joint interpolation */
  motion?: "lin" | "circ";
  via?: Vec3;
}

export function poseTarget(twin: Twin, real: Vec3, orientation: Quaternion | undefined, motion?: string, via?: Vec3): PoseTarget {
  const position = twin.frames.pointToVirtual(real);
  const how = motion === "lin" ? { motion: "lin" as const } : motion === "circ" ? { motion: "circ" as const } : {};
  // the via point travels in the same frame as the target (real frame in, virtual frame to the backend)
  const through = via !== undefined ? { via: twin.frames.pointToVirtual(via) } : {};
  return orientation ? { position, orientation: quatArr(twin.frames.quatToVirtual(orientation)), ...how, ...through } : { position, ...how, ...through };
}

/** The static checks of a Cartesian target on workspace.stl and workspace.csv, and their evidence. */
export function staticChecks(ws: WorkspaceChecks | null, virtual: Vec3): { checks: ValidationReport["checks"]; evidence: string[] } {
  const checks: ValidationReport["checks"] = {};
  const evidence: string[] = [];
  if (!ws) return { checks, evidence };
  const where = `(${virtual.map(fmt).join(", ")}) m in the twin frame`;
  checks.insideWorkspace = { ok: ws.inside(virtual) };
  if (!checks.insideWorkspace.ok) evidence.push(`target ${where} is outside the workspace surface (${TWIN_FILES.surface})`);
  checks.pointCloud = ws.score(virtual);
  if (!checks.pointCloud.ok) {
    const nearest = checks.pointCloud.nearestFree < 0 ? "none at all" : `nearest ${fmt(checks.pointCloud.nearestFree)} m`;
    evidence.push(`no collision-free sample of ${TWIN_FILES.pointCloud} within ${fmt(checks.pointCloud.maxGap)} m of ${where} (${nearest})`);
  }
  const reach = ws.reach(virtual);
  if (reach) {
    checks.reachability = reach;
    if (!reach.ok) evidence.push(`no collision-free sample ends in the ${fmt(reach.voxel)} m voxel of ${where} (${TWIN_FILES.reachability})`);
  }
  return { checks, evidence };
}

/** The report of a plan (valid or not) with the static checks beside it. */
export function report(plan: Pick<Plan, "valid" | "reasons"> & { checks: PlanChecks }, statics = staticChecks(null, [0, 0, 0])): ValidationReport {
  const notes = plan.valid ? statics.evidence.map((s) => `${s}; the simulation reaches it collision-free, so it is accepted`) : statics.evidence;
  const path = plan.checks.path ? { path: { ...plan.checks.path, contacts: plan.checks.path.contacts.map(tdContact) } } : {};
  return { valid: plan.valid, reasons: plan.reasons, checks: { ...statics.checks, ...plan.checks, ...path }, ...(notes.length > 0 ? { notes } : {}) };
}

export async function validateJoints(backend: Pick<BackendSupervisor, "sim">, twin: Twin, q: number[], speed: number): Promise<ValidationReport> {
  return report(await backend.sim.plan({ robot: twin.robotId, target: q, speed }));
}

export async function validateCartesian(backend: Pick<BackendSupervisor, "sim">, twin: Twin, ws: WorkspaceChecks | null, target: PoseTarget, speed: number): Promise<ValidationReport> {
  const statics = staticChecks(ws, target.position);
  return report(await backend.sim.plan({ robot: twin.robotId, ...target, speed }), statics);
}
