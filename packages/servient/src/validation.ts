/**
 * Simulation-in-the-loop validation (the original's key idea): before a move, and for the validate*
 * actions, check joint limits, the workspace surface (workspace.stl), the point-cloud score
 * (workspace.csv), IK reachability and collision along the whole path in the current scene.
 *
 * Policy: the simulation decides. `valid` is the verdict of the strongest checks — reachable by IK within
 * limits and a collision-free path (with clearance) in the current scene. The static checks on the
 * linked files (inside workspace.stl, point-cloud score) are the evidence a consumer without the twin
 * has; they are computed and reported in `checks` (and, when they disagree with the simulation, in
 * `notes`), but a weaker check never vetoes a stronger one. Nothing here moves the twin.
 */
import type { Contact, Quaternion, ValidationReport, Vec3 } from "@robwot/core";
import type { BackendSupervisor } from "./backend.js";
import { ServientError } from "./errors.js";
import { quatArr } from "./frames.js";
import type { Twin } from "./twin.js";
import type { WorkspaceChecks } from "./workspace-checks.js";

/** IK answers farther than this from the target count as unreachable (m). */
export const IK_TOLERANCE = 1e-3;

export interface JointPlan {
  report: ValidationReport;
  target: number[];
}

export interface CartesianPlan extends JointPlan {
  /** target in the virtual frame */
  virtual: Vec3;
  positionError: number;
}

const fmt = (v: number): string => (Math.abs(v) >= 1e-3 || v === 0 ? v.toFixed(4) : v.toExponential(2));

function limitsCheck(twin: Twin, q: number[]): NonNullable<ValidationReport["checks"]["limits"]> {
  const violations: { joint: string; value: number; lower: number; upper: number }[] = [];
  const byName = new Map((twin.model?.joints ?? []).map((j) => [j.name, j]));
  twin.joints.forEach((name, i) => {
    const j = byName.get(name);
    const v = q[i] as number;
    if (j && (v < j.lower - 1e-9 || v > j.upper + 1e-9)) violations.push({ joint: name, value: v, lower: j.lower, upper: j.upper });
  });
  return violations.length ? { ok: false, violations } : { ok: true };
}

async function pathCheck(
  backend: BackendSupervisor,
  twin: Twin,
  target: number[],
  speed: number,
): Promise<NonNullable<ValidationReport["checks"]["path"]>> {
  const r = await backend.sim.checkPath({ robot: twin.robotId, target, from: twin.q, speed });
  return { ok: r.collisionFree, contacts: r.firstCollision?.contacts ?? [] };
}

function describeContact(c: Contact | undefined): string {
  if (!c) return "";
  const side = (s: { body: string; link: string | null }): string => (s.link ? `${s.body}/${s.link}` : s.body);
  return ` (${side(c.a)} touches ${side(c.b)}, depth ${fmt(c.depth)} m)`;
}

export async function validateJoints(backend: BackendSupervisor, twin: Twin, q: number[], speed: number): Promise<JointPlan> {
  const reasons: string[] = [];
  const checks: ValidationReport["checks"] = {};
  checks.limits = limitsCheck(twin, q);
  for (const v of checks.limits.violations ?? []) {
    reasons.push(`joint ${v.joint} = ${fmt(v.value)} outside its limits [${fmt(v.lower)}, ${fmt(v.upper)}]`);
  }
  if (checks.limits.ok) {
    checks.path = await pathCheck(backend, twin, q, speed);
    if (!checks.path.ok) reasons.push(`the path to the target collides${describeContact(checks.path.contacts[0])}`);
  }
  return { report: { valid: reasons.length === 0, reasons, checks }, target: q };
}

export async function validateCartesian(
  backend: BackendSupervisor,
  twin: Twin,
  ws: WorkspaceChecks | null,
  real: Vec3,
  orientation: Quaternion | undefined,
  speed: number,
): Promise<CartesianPlan> {
  const reasons: string[] = [];
  const evidence: string[] = [];
  const checks: ValidationReport["checks"] = {};
  const virtual = twin.frames.pointToVirtual(real);
  const where = `(${virtual.map(fmt).join(", ")}) m in the twin frame`;
  if (ws) {
    checks.insideWorkspace = { ok: ws.inside(virtual) };
    if (!checks.insideWorkspace.ok) evidence.push(`target ${where} is outside the workspace surface (workspace.stl)`);
    checks.pointCloud = ws.score(virtual);
    if (!checks.pointCloud.ok) {
      evidence.push(
        `point-cloud score ${fmt(checks.pointCloud.score)} > threshold ${checks.pointCloud.threshold} ` +
          `(share of colliding samples among the ${checks.pointCloud.k} nearest in workspace.csv)`,
      );
    }
  }
  let target: number[] = [];
  let positionError = Infinity;
  try {
    const ik = await backend.sim.ik({
      robot: twin.robotId,
      position: virtual,
      seed: twin.q,
      collisionFree: true,
      ...(orientation ? { orientation: quatArr(twin.frames.quatToVirtual(orientation)) } : {}),
    });
    target = ik.positions;
    positionError = ik.positionError;
    const ok = ik.positionError <= IK_TOLERANCE && ik.collisionFree;
    checks.ik = { ok, positionError: ik.positionError };
    if (!ok) reasons.push(`IK found no collision-free solution within ${IK_TOLERANCE} m of ${where} (error ${fmt(ik.positionError)} m)`);
  } catch (err) {
    if (!(err instanceof ServientError) || err.code !== "E_UNREACHABLE") throw err;
    const pe = typeof err.details.positionError === "number" ? err.details.positionError : Infinity;
    checks.ik = { ok: false, positionError: Number.isFinite(pe) ? pe : -1 };
    reasons.push(`target ${where} is not reachable by IK: ${err.message}`);
  }
  if (checks.ik?.ok) {
    checks.limits = limitsCheck(twin, target);
    if (!checks.limits.ok) reasons.push("the IK solution violates joint limits");
    else {
      checks.path = await pathCheck(backend, twin, target, speed);
      if (!checks.path.ok) reasons.push(`the path to the target collides${describeContact(checks.path.contacts[0])}`);
    }
  }
  const valid = reasons.length === 0;
  // the static evidence, where it disagrees with the simulation's verdict (it never vetoes it)
  const notes = valid ? evidence.map((s) => `${s}; the simulation reaches it collision-free, so it is accepted`) : evidence;
  return { report: { valid, reasons, checks, ...(notes.length > 0 ? { notes } : {}) }, target, virtual, positionError };
}
