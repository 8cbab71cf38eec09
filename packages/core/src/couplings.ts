/**
 * Joints that follow others (the backend's `Coupling`: URDF `<mimic>` tags, `--couple` rules and the
 * rules `--keep-level` derives), as a twin's TD states them (`robwot:couplings`): each follower's value is
 * `sum(factor * joint) + offset` over the controllable joints. Browser-safe.
 */
import type { Coupling } from "./backend-contract.js";

/** The TD term: what a consumer needs to place every link (the viewer draws followers with it). */
export type TdCoupling = Pick<Coupling, "follower" | "terms" | "offset" | "expression" | "source">;

/** The TD's `robwot:couplings`, or none; a malformed entry is left out (it cannot be drawn). */
export function tdCouplings(td: Record<string, unknown>): TdCoupling[] {
  const raw = td["robwot:couplings"];
  if (!Array.isArray(raw)) return [];
  return raw.filter((c): c is TdCoupling => {
    const o = c as Partial<TdCoupling> | null;
    return typeof o?.follower === "string" && typeof o.offset === "number" && Array.isArray(o.terms) &&
      o.terms.every((t) => typeof t?.joint === "string" && typeof t.factor === "number");
  });
}

/** `joints` (controllable joint -> value) with every follower's value added; a leader absent from
 * `joints` counts as 0. */
export function withFollowers(joints: Record<string, number>, couplings: readonly TdCoupling[]): Record<string, number> {
  if (couplings.length === 0) return joints;
  const out = { ...joints };
  for (const c of couplings) {
    out[c.follower] = c.terms.reduce((sum, t) => sum + t.factor * (joints[t.joint] ?? 0), c.offset);
  }
  return out;
}
