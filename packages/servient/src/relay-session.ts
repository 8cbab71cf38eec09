/**
 * Relaying a move the simulation has completed to the physical robot (`--relay`): its legs (a detour's,
 * a program's steps) one after the other, each once the previous one is answered, within one deadline
 * for the whole move (`RELAY_MOVE_DEADLINE`); the first leg that fails ends the relay, and the report
 * says which.
 *
 * The physical robot gets a command only after the simulated motion has reached its target, so a move
 * the simulation ends early never reaches it. From the moment a command is relayed until the physical
 * Thing answers, every path that ends the move early stops the physical robot, once per move: the
 * deadline passing or the connection failing mid-command (no answer: the command may be running there
 * unwatched), the simulation backend going down (the simulation that validated the command is gone),
 * servient shutdown (`shutdown`), and a stop (the motion session sends its own; the relay stops waiting).
 */
import type { PendingMove } from "./motion-session.js";
import type { RelayLeg } from "./move-input.js";
import type { TrajectoryState } from "./motion-record.js";
import { answered, type PhysicalStopReport, type Relay, type RelayReport } from "./relay.js";
import type { Twin } from "./twin.js";

/**
 * A relayed move that the physical robot has not answered within `factor` times the simulated motion's
 * duration plus `marginMs` is stopped there: the physical robot is expected to move like its twin.
 */
export const RELAY_MOVE_DEADLINE = { factor: 3, marginMs: 10_000 };

/** The part of the backend supervisor the relay listens to: the backend went down (`BackendSupervisor`'s event). */
export interface DownSignal {
  on(event: "down", listener: (reason: string) => void): unknown;
}

/** A program's relay: each step relayed until the first that failed. */
export interface ProgramRelayReport {
  ok: boolean;
  steps: { step: number; ok: boolean; error?: string }[];
  error?: string;
}

/** A move while one of its commands is relayed and not yet answered, and the twin's stop of it, once sent. */
interface ActiveRelay {
  move: PendingMove;
  stop?: { reason: string; report: Promise<PhysicalStopReport> };
}

export class RelaySession {
  private active: ActiveRelay | null = null;

  constructor(
    private readonly relay: Relay,
    private readonly twin: Twin,
    backend: DownSignal,
  ) {
    // the simulation that validated a relayed command is gone: the physical robot does not run on unwatched
    backend.on("down", (reason) => {
      if (this.active) this.stopPhysical(this.active, `simulation backend down: ${reason}`);
    });
  }

  /** The physical robot's stop, sent at once and retried (`Relay.stop`). */
  stopNow(): Promise<PhysicalStopReport> {
    return this.relay.stop();
  }

  /**
   * Servient shutdown: when a relayed command may be running on the physical robot, stops it there; the
   * stop's report, to cancel the move with, or undefined when nothing was relayed.
   */
  shutdown(): Promise<PhysicalStopReport> | undefined {
    return this.active ? this.stopPhysical(this.active, "servient shutting down").report : undefined;
  }

  /**
   * Relays a move as its legs, sent one after the other, each once the previous one is answered, at most
   * `RELAY_MOVE_DEADLINE` after the simulated `duration` (s) in all; past it the physical robot is
   * stopped. `states` are the simulated states the physical robot should follow (the follower's
   * divergence and monitor read them). When the twin stopped the physical robot the report says why.
   */
  async move(move: PendingMove, legs: readonly RelayLeg[], duration: number, states: readonly TrajectoryState[] = this.twin.motion.trajectory): Promise<RelayReport> {
    const relay = this.relay;
    const deadline = Date.now() + Math.ceil(duration * 1000 * RELAY_MOVE_DEADLINE.factor + RELAY_MOVE_DEADLINE.marginMs);
    const active: ActiveRelay = { move };
    this.active = active;
    this.twin.motion.relayStart(states, Date.now());
    let r: RelayReport = { ok: false, target: relay.url, action: legs[0]?.action ?? "", error: "nothing relayed" };
    try {
      for (const [k, leg] of legs.entries()) {
        if (move.cancelled) break;
        // a stop ends the relayed command's wait at once (its own stop to the physical robot is on its way)
        const stopped = move.whenCancelled.then((): RelayReport => ({ ok: false, target: relay.url, action: leg.action, error: "stopped" }));
        r = await Promise.race([relay.forward(leg.action, leg.input, Math.max(1, deadline - Date.now())), stopped]);
        if (legs.length > 1) r = { ...r, leg: k, legs: legs.length };
        // no answer in time, or the connection failed mid-command: the command may be running there
        if (!answered(r) && !move.cancelled) this.stopPhysical(active, `relayed ${leg.action} without an answer (${r.error})`);
        if (!r.ok) break;
      }
    } finally {
      this.active = null;
      this.twin.motion.relayEnd();
    }
    if (active.stop) {
      const s = await active.stop.report;
      const how = s.ok ? `stop confirmed after ${s.attempts} attempt(s)` : `stop not confirmed: ${s.error}`;
      r = { ...r, ok: false, error: `stopped by the twin (${active.stop.reason}); ${how}` };
    }
    if (!r.ok) this.twin.setStatus({ lastError: { code: "E_RELAY", message: `relay to the physical robot failed: ${r.error}` } });
    return r;
  }

  /**
   * A program's steps relayed one after the other, each like a move (`move`) with its own deadline from
   * its simulated duration, and the simulated states of that step; ends at the first step that fails.
   */
  async program(move: PendingMove, legs: readonly RelayLeg[], durations: readonly number[]): Promise<ProgramRelayReport> {
    const reports: ProgramRelayReport["steps"] = [];
    const recorded = this.twin.motion.trajectory;
    for (const [k, leg] of legs.entries()) {
      if (move.cancelled) return { ok: false, steps: reports, error: `stopped before step ${k}` };
      // the states of step k, from where the previous one ended
      const mine = recorded.flatMap((s, i) => (s.step === k ? [i] : []));
      const states = mine.length === 0 ? [] : recorded.slice(Math.max(0, mine[0]! - 1), mine[mine.length - 1]! + 1);
      const r = await this.move(move, [leg], durations[k] ?? 0, states);
      reports.push(r.ok ? { step: k, ok: true } : { step: k, ok: false, error: r.error ?? "failed" });
      if (!r.ok) return { ok: false, steps: reports, error: `step ${k}: ${r.error ?? "failed"}` };
    }
    return { ok: true, steps: reports };
  }

  /** Stops the physical robot for the relayed move once (later reasons reuse the first stop). */
  private stopPhysical(active: ActiveRelay, reason: string): { reason: string; report: Promise<PhysicalStopReport> } {
    if (!active.stop) {
      active.stop = { reason, report: this.relay.stop() };
      this.twin.setStatus({ lastError: { code: "E_RELAY", message: `physical robot stopped: ${reason}` } });
    }
    return active.stop;
  }
}
