/**
 * Relay (`--relay <TD URL>`): after the twin has validated and performed a command, the same command
 * (Cartesian targets in the real frame, i.e. already "mapped through the calibration") is sent to the
 * physical robot's Thing, consumed with node-wot. A failure there is reported in the move result
 * (`relay: {ok: false, error}`) and in motionStatus.lastError (`E_RELAY`), never hidden.
 *
 * A stop to the physical robot (`stop`) is retried until the physical Thing answers or
 * `STOP_DEADLINE_MS` passes: an attempt that fails is repeated after a short pause, one that has not
 * answered after `STOP_ATTEMPT_MS` is followed by another while it may still answer (the first answer
 * wins). An attempt to a hung Thing ends at the transport's own deadlines (`outbound.ts`); stops asked for
 * while one is being sent join it, so each stop reaches the physical robot once.
 */
import type { RelayReport } from "@robwot/core";
import { toPhysical, type RelayMap } from "./relay-map.js";

/** A stop to the physical robot is retried until it answers or this deadline passes (ms). */
export const STOP_DEADLINE_MS = 5_000;
/** A stop attempt without an answer after this long (ms) is followed by another. */
export const STOP_ATTEMPT_MS = 1_000;
/** Pause (ms) after a failed stop attempt before the next. */
const STOP_RETRY_PAUSE_MS = 100;

/** The part of node-wot's WoT API the relay needs. */
export interface WoTLike {
  requestThingDescription(url: string): Promise<unknown>;
  consume(td: unknown): Promise<ConsumedLike>;
}

interface ConsumedLike {
  invokeAction(name: string, input?: unknown): Promise<{ value(): Promise<unknown> } | undefined>;
}

export type { RelayReport };

/** The physical robot's part of a `stop` answer. */
export interface PhysicalStopReport {
  /** the physical Thing answered the stop */
  ok: boolean;
  /** stop requests sent */
  attempts: number;
  /** the physical Thing said it stopped something (its `stopped`; true when its answer has none) */
  stopped: boolean;
  error?: string;
}

const message = (err: unknown): string => (err instanceof Error ? err.message : String(err));

/**
 * Whether the physical Thing answered the command (a result, or an HTTP error status: node-wot's
 * `Client error: ...` / `Server error: ...`), as opposed to no answer (timeout, connection lost), after
 * which the command may be running there unwatched.
 */
export function answered(r: RelayReport): boolean {
  return r.result !== undefined || /^(Client|Server) error\b/.test(r.error ?? "");
}

export class Relay {
  private thing: ConsumedLike | null = null;
  /** relayed commands other than `stop` sent and not yet answered */
  private inFlight = 0;

  constructor(
    private readonly wot: WoTLike,
    readonly url: string,
    /** the physical Thing's own names (`--relay-map`); null: the twin's */
    private readonly map: RelayMap | null = null,
  ) {}

  /** Fetches and consumes the physical robot's TD (also retried lazily by `forward`); returns the TD. */
  async connect(): Promise<unknown> {
    const td = await this.wot.requestThingDescription(this.url);
    this.thing = await this.wot.consume(td);
    return td;
  }

  /**
   * Sends one command and waits for its answer. With `timeoutMs` > 0 the report says `ok: false` once
   * that time has passed without an answer (the command may still be running on the physical robot:
   * the caller decides whether to stop it).
   */
  async forward(action: string, input: unknown, timeoutMs = 0): Promise<RelayReport> {
    const base = { target: this.url, action };
    const counted = action !== "stop";
    if (counted) this.inFlight++;
    const sent = this.send(action, input).finally(() => {
      if (counted) this.inFlight--;
    });
    if (timeoutMs <= 0) return sent;
    let timer: NodeJS.Timeout | undefined;
    const late = new Promise<RelayReport>((resolve) => {
      timer = setTimeout(() => resolve({ ...base, ok: false, error: `the physical robot did not answer ${action} within ${timeoutMs} ms` }), timeoutMs);
    });
    return Promise.race([sent, late]).finally(() => clearTimeout(timer));
  }

  private async send(action: string, input: unknown): Promise<RelayReport> {
    const base = { target: this.url, action };
    try {
      if (!this.thing) await this.connect();
      const sent = this.map ? toPhysical(this.map, action, input) : { action, input };
      const out = await (this.thing as ConsumedLike).invokeAction(sent.action, sent.input);
      // an action declaring no output (any Thing's; a vendor's, mapped, may also answer what it does not
      // declare): that it answered is the answer
      const value = out ? await (this.map ? out.value().catch(() => null) : out.value()) : null;
      const result = value ?? {};
      const status = (result as { status?: unknown } | undefined)?.status;
      if (typeof status === "string" && status !== "reached" && action !== "stop") {
        return { ...base, ok: false, result, error: `physical robot ended its motion with status "${status}"` };
      }
      return { ...base, ok: true, result };
    } catch (err) {
      return { ...base, ok: false, error: message(err) };
    }
  }

  /**
   * Stops the physical robot: sent at once, repeated until the Thing answers or `deadlineMs` passes.
   * An answer `stopped: false` while one of our commands is still in flight is not taken as final: that
   * command may not have reached the robot yet, and the stop must catch it.
   */
  stop(deadlineMs = STOP_DEADLINE_MS): Promise<PhysicalStopReport> {
    // stops asked for while one is being sent join it: each reaches the physical robot once
    this.stopping ??= this.sendStop(deadlineMs).finally(() => (this.stopping = null));
    return this.stopping;
  }

  private stopping: Promise<PhysicalStopReport> | null = null;

  private sendStop(deadlineMs: number): Promise<PhysicalStopReport> {
    return new Promise<PhysicalStopReport>((resolve) => {
      let attempts = 0;
      let lastError = "";
      /** the Thing answered, but `stopped: false` while a command of ours was in flight */
      let answeredNothing = false;
      let done = false;
      let next: NodeJS.Timeout | null = null;
      const finish = (r: PhysicalStopReport): void => {
        if (done) return;
        done = true;
        clearTimeout(deadline);
        if (next) clearTimeout(next);
        resolve(r);
      };
      const deadline = setTimeout(
        () =>
          finish(
            answeredNothing
              ? { ok: true, attempts, stopped: false }
              : { ok: false, attempts, stopped: false, error: `no answer to stop within ${deadlineMs} ms${lastError ? ` (last: ${lastError})` : ""}` },
          ),
        deadlineMs,
      );
      const schedule = (ms: number): void => {
        if (next) clearTimeout(next);
        next = setTimeout(attempt, ms);
      };
      const attempt = (): void => {
        if (done) return;
        attempts++;
        // an attempt still unanswered after STOP_ATTEMPT_MS is followed by another; it may still answer
        schedule(STOP_ATTEMPT_MS);
        void this.send("stop", undefined).then((r) => {
          if (done) return;
          if (!r.ok) {
            lastError = r.error ?? "stop failed";
            schedule(STOP_RETRY_PAUSE_MS);
            return;
          }
          const stopped = (r.result as { stopped?: unknown } | undefined)?.stopped;
          if (stopped === false && this.inFlight > 0) {
            answeredNothing = true;
            schedule(STOP_RETRY_PAUSE_MS);
            return;
          }
          finish({ ok: true, attempts, stopped: stopped !== false });
        });
      };
      attempt();
    });
  }
}
