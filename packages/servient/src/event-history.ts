/**
 * Sequence numbers and the bounded history of one event stream, for clients that resume (SSE
 * `Last-Event-ID`, `/live` `resume`): what a client that last saw number n missed, and whether some of
 * it is no longer known.
 *
 * Numbers increase by one per message of the stream; the first is the stream's creation time in ms x
 * 1000 + 1, so they keep increasing across restarts of the servient (a run sends fewer than 1000
 * messages per ms) and a number of an earlier run is recognised as such: what came after it in that run
 * is unknown ("restart"). A number older than the oldest kept one: "overflow".
 */
import { PUSH_LIMITS } from "./push-queue.js";

/** Messages kept per stream: a full replay and its gap notice fit in a client's queue (push-queue.ts). */
export const EVENT_HISTORY = PUSH_LIMITS.maxEvents - 1;

export interface Gap {
  /** the number the client resumed from */
  lastSeen: number;
  /** the oldest number still kept, null when none is */
  firstKept: number | null;
  reason: "overflow" | "restart";
}

/** The numbers of a stream, one per message (kept or not): increasing, also across restarts. */
export class Sequence {
  readonly first: number;
  private next: number;

  constructor(now = Date.now()) {
    this.first = now * 1000 + 1;
    this.next = this.first;
  }

  take(): number {
    return this.next++;
  }

  /** true when `n` has not been given yet */
  isAhead(n: number): boolean {
    return n >= this.next;
  }
}

/** The last `limit` messages of a stream under their numbers (several histories may share one Sequence). */
export class EventHistory<T> {
  private readonly kept: { seq: number; message: T }[] = [];
  /** the highest number no longer kept (only numbers of this history count) */
  private forgotten: number;

  constructor(
    readonly numbers = new Sequence(),
    private readonly limit = EVENT_HISTORY,
  ) {
    this.forgotten = numbers.first - 1;
  }

  /** Keeps `make(seq)` under the next number and returns it. */
  record(make: (seq: number) => T): T {
    const seq = this.numbers.take();
    const message = make(seq);
    this.kept.push({ seq, message });
    if (this.kept.length > this.limit) this.forgotten = this.kept.shift()!.seq;
    return message;
  }

  /** The kept messages after `lastSeen`, oldest first, and the gap before them when some are unknown. */
  since(lastSeen: number): { replay: T[]; gap: Gap | null } {
    const replay = this.kept.filter((k) => k.seq > lastSeen).map((k) => k.message);
    // a number not yet given (a clock set back since) has nothing after it to replay
    if (lastSeen >= this.forgotten || this.numbers.isAhead(lastSeen)) return { replay, gap: null };
    const reason = lastSeen < this.numbers.first - 1 ? "restart" : "overflow";
    return { replay, gap: { lastSeen, firstKept: this.kept[0]?.seq ?? null, reason } };
  }
}

/** A resume point from a header or query parameter: a decimal integer, null when absent or malformed. */
export function resumePoint(raw: string | string[] | null | undefined): number | null {
  const text = (Array.isArray(raw) ? raw[0] : raw)?.trim() ?? "";
  return /^\d{1,16}$/.test(text) ? Number(text) : null;
}
