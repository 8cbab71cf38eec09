/**
 * While a move is relayed to the physical robot, each reading is compared with the simulated motion at the
 * same time since the command was sent (`Twin.motion.relayed`; the simulated states interpolated, the last one
 * held): `divergence` (largest joint difference, end-effector distance) and its largest value during the
 * command; passing the bound emits the `divergence` event once per relayed command.
 */
import type { Vec3 } from "@robwot/core";
import { expectedAt, jointGap } from "./joint-path.js";
import type { Twin } from "./twin.js";

export class Divergence {
  private current: { joint: number; tcp: number } | null = null;
  private max: { joint: number; tcp: number; sentAt: number; reported: boolean } | null = null;

  constructor(
    private readonly twin: Twin,
    /** rad or m */
    readonly bound: number,
  ) {}

  /** `physicalState`'s `divergence` and `maxDivergence`, when there are any. */
  view(): { divergence?: { joint: number; tcp: number }; maxDivergence?: { joint: number; tcp: number; bound: number } } {
    return {
      ...(this.current ? { divergence: this.current } : {}),
      ...(this.max ? { maxDivergence: { joint: this.max.joint, tcp: this.max.tcp, bound: this.bound } } : {}),
    };
  }

  /** A reading `q` (end effector at `position`, virtual frame) that arrived at `at` (ms). */
  compare(q: number[], position: Vec3, at: number): void {
    const relayed = this.twin.motion.relayed;
    if (!relayed) {
      this.current = null;
      return;
    }
    const t = (at - relayed.sentAt) / 1000;
    const expected = expectedAt(relayed.states, t);
    if (!expected) return;
    const joint = jointGap(q, expected.q);
    const tcp = Math.hypot(...position.map((v, i) => v - (expected.position[i] ?? v)));
    this.current = { joint, tcp };
    if (this.max?.sentAt !== relayed.sentAt) this.max = { joint: 0, tcp: 0, sentAt: relayed.sentAt, reported: false };
    const max = this.max;
    max.joint = Math.max(max.joint, joint);
    max.tcp = Math.max(max.tcp, tcp);
    if (joint > this.bound && !max.reported) {
      max.reported = true;
      this.twin.emit("divergence", { joint, tcp, time: t, bound: this.bound, joints: this.twin.jointsRecord(q), expected: this.twin.jointsRecord(expected.q) });
    }
  }
}
