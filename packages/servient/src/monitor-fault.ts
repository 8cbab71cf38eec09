/**
 * What the follower does when the safety monitor cannot see the physical robot (`follow.ts` decides when),
 * and the monitor's stop to the physical robot.
 *
 * A fault is said on every surface at once: `physicalState.monitorFault` (since when, why, the stop sent
 * for it), `motionStatus.lastError` (`E_MONITOR_BLIND`), the `physical` change /live and SSE push, and a
 * process warning; with mode `stop` the robot is stopped once per fault. It ends with the next usable
 * reading, which clears `motionStatus.lastError` if that still is the fault's.
 *
 * A stop has a deadline: a stop asked for while the previous one is unanswered and within its deadline
 * shares that one's outcome (a fault and a predicted contact at once send one request); an answered stop or
 * one past its deadline is followed by a new request, so a stop lost on its way is not the last one. Stops are asked for once per fault and once
 * per approach, never per reading: a Thing that never answers them holds that many requests, each until
 * the HTTP client's own deadline.
 */
import { withDeadline } from "./deadline.js";
import type { MonitorMode, StopOutcome } from "./monitor.js";
import { clip } from "./reading.js";
import type { Twin } from "./twin.js";

/** `motionStatus.lastError.code` (and `physicalState.monitorFault.code`) of a monitor that cannot see the robot */
export const MONITOR_BLIND = "E_MONITOR_BLIND";

/** `physicalState.monitorFault`: the monitor cannot see the robot. */
export interface MonitorFault {
  code: string;
  /** the last usable reading (or the start), ISO 8601 */
  since: string;
  /** when the fault was declared */
  detected: string;
  reason: string;
  /** mode `stop`: the stop sent for this fault */
  stop?: { state: "pending" | "answered" | "failed"; error?: string };
}

const message = (err: unknown): string => clip(err instanceof Error ? err.message : String(err));

/** The physical robot's stop action, bounded by `deadlineMs`, one at a time. */
export class BoundedStop {
  private current: { outcome: Promise<StopOutcome>; due: number; settled: boolean } | null = null;

  constructor(
    /** sends the stop; null when it cannot be sent (the reason) */
    private readonly send: () => Promise<unknown> | string,
    private readonly deadlineMs: number,
    private readonly what: string,
  ) {}

  /** Resolves (never rejects) once the stop is answered or past its deadline. */
  stop(): Promise<StopOutcome> {
    const c = this.current;
    if (c && !c.settled && Date.now() < c.due) return c.outcome;
    const raw = this.send();
    if (typeof raw === "string") return Promise.resolve({ ok: false, error: raw });
    const entry = { outcome: Promise.resolve<StopOutcome>({ ok: false }), due: Date.now() + this.deadlineMs, settled: false };
    entry.outcome = withDeadline(raw, this.deadlineMs, this.what).then(
      (): StopOutcome => ({ ok: true }),
      (err: unknown): StopOutcome => ({ ok: false, error: message(err) }),
    );
    const settle = (): void => void (entry.settled = true);
    void raw.then(settle, settle);
    this.current = entry;
    return entry.outcome;
  }
}

export class BlindWatch {
  private fault: { since: number; detected: number; reason: string; stop?: MonitorFault["stop"] } | null = null;
  /** faults declared so far */
  count = 0;

  constructor(
    private readonly twin: Twin,
    private readonly mode: MonitorMode,
    private readonly stop: () => Promise<StopOutcome>,
    private readonly onChange: () => void,
  ) {}

  get active(): boolean {
    return this.fault !== null;
  }

  /** Declares a fault (the robot unseen since `since`, ms) on every surface; with mode `stop`, stops it. */
  declare(now: number, since: number, reason: string): void {
    const fault: NonNullable<BlindWatch["fault"]> = { since, detected: now, reason: clip(reason) };
    this.fault = fault;
    this.count++;
    this.twin.setStatus({ lastError: { code: MONITOR_BLIND, message: fault.reason } });
    process.emitWarning(`robwot serve: ${fault.reason}`, { code: "ROBWOT_MONITOR_BLIND" });
    if (this.mode === "stop") {
      fault.stop = { state: "pending" };
      void this.stop().then((outcome) => {
        fault.stop = outcome.ok ? { state: "answered" } : { state: "failed", ...(outcome.error ? { error: outcome.error } : {}) };
        if (this.fault === fault) this.onChange();
      });
    }
    this.onChange();
  }

  /** While the fault lasts: a move's end may have cleared motionStatus.lastError, the fault still holds. */
  hold(): void {
    if (this.fault && !this.twin.status.lastError) this.twin.setStatus({ lastError: { code: MONITOR_BLIND, message: this.fault.reason } });
  }

  /** A usable reading: the fault ends. */
  end(): void {
    if (!this.fault) return;
    this.fault = null;
    if (this.twin.status.lastError?.code === MONITOR_BLIND) this.twin.setStatus({ lastError: null });
    this.onChange();
  }

  view(): MonitorFault | undefined {
    const f = this.fault;
    if (!f) return undefined;
    return { code: MONITOR_BLIND, since: new Date(f.since).toISOString(), detected: new Date(f.detected).toISOString(), reason: f.reason, ...(f.stop ? { stop: { ...f.stop } } : {}) };
  }
}
