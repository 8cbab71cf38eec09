/**
 * The per-client queue of every push channel (`/live` WebSocket, SSE): bounded, coalescing, and the one
 * place that decides when a client is too slow to keep.
 *
 * - A keyed message replaces the queued message of its key, which it follows in the delivery order
 *   (a thing's joints, status, scene: a viewer needs the latest of each, not the history).
 * - Unkeyed messages (events, replies) are kept in order, at most `maxEvents` of them; one more means
 *   the client is behind: it is disconnected rather than silently losing an event.
 * - Messages go to the transport only while it holds fewer than `highWater` bytes the OS has not taken,
 *   so a client costs at most `highWater` + one message in the transport, plus one queued message per
 *   key and `maxEvents` events here: no amount of pushing grows it further.
 * - A client with messages waiting whose transport hands none of its bytes to the OS for `stallMs` is
 *   disconnected with a reason (WebSocket close frame, SSE comment); a connection still open
 *   `closeGraceMs` later is destroyed (a client that reads nothing would hold it forever).
 */
import { createLoggers } from "@node-wot/core";

const { warn } = createLoggers("robwot", "push");

export interface PushLimits {
  /** bytes in the transport (written, not yet taken by the OS) above which nothing more is written */
  highWater: number;
  /** undelivered unkeyed messages a client may have */
  maxEvents: number;
  /** how long a client with waiting messages may take none of them */
  stallMs: number;
  /** how long a disconnected client's connection may stay open to receive the reason */
  closeGraceMs: number;
}

export const PUSH_LIMITS: PushLimits = { highWater: 16 * 1024, maxEvents: 64, stallMs: 10_000, closeGraceMs: 30_000 };

/** What a queue writes to: one client's connection. */
export interface PushTransport<T> {
  /** bytes written and not yet taken by the OS */
  buffered(): number;
  /** writes one message; `done` once the OS has taken it */
  write(message: T, done: () => void): void;
  /** ends the connection, telling the client why */
  close(reason: string): void;
  /** ends the connection at once */
  destroy(): void;
}

/** One kind's place in the queue: reused for every message of its key (`order` 0 = nothing waiting). */
interface Slot<T> {
  message: T | null;
  order: number;
}

export class PushQueue<T> {
  // Slots are created once per key and then only overwritten: a push allocates nothing here. (A Map of
  // messages deleted and re-set on every push reallocates its table again and again, and the tables of
  // a long-lived Map go straight to V8's old space: garbage only a full collection frees.)
  private readonly slots = new Map<string, Slot<T>>();
  private readonly events: { message: T; order: number }[] = [];
  private waiting = 0;
  private seq = 0;
  /** when the transport last took a message, or when the client became behind, whichever is later */
  private progressAt = 0;
  private stallTimer: NodeJS.Timeout | null = null;
  private graceTimer: NodeJS.Timeout | null = null;
  private ended = false;

  constructor(
    private readonly transport: PushTransport<T>,
    private readonly client: string,
    private readonly limits: PushLimits = PUSH_LIMITS,
  ) {}

  /** true once disconnected (or disposed): pushes are ignored */
  get closed(): boolean {
    return this.ended;
  }

  /** Queues `message`; `key` = the kind it coalesces with (null: an event, kept). */
  push(key: string | null, message: T): void {
    if (this.ended) return;
    if (key === null) {
      if (this.events.length >= this.limits.maxEvents) {
        this.disconnect(`too slow: more than ${this.limits.maxEvents} events undelivered`);
        return;
      }
      this.events.push({ message, order: ++this.seq });
      this.waiting++;
    } else {
      let slot = this.slots.get(key);
      if (!slot) this.slots.set(key, (slot = { message: null, order: 0 }));
      if (slot.order === 0) this.waiting++;
      slot.message = message;
      slot.order = ++this.seq;
    }
    this.flush();
  }

  /** The connection is gone: forget everything, stop the timers. */
  dispose(): void {
    this.ended = true;
    this.forget();
    this.clearTimers();
  }

  /** The message waiting longest (in the order of the pushes that left it there), taken out. */
  private take(): T {
    let first: Slot<T> | null = null;
    for (const slot of this.slots.values()) if (slot.order !== 0 && (first === null || slot.order < first.order)) first = slot;
    const event = this.events[0];
    this.waiting--;
    if (event && (first === null || event.order < first.order)) return this.events.shift()!.message;
    const message = first!.message as T;
    first!.message = null;
    first!.order = 0;
    return message;
  }

  private forget(): void {
    for (const slot of this.slots.values()) {
      slot.message = null;
      slot.order = 0;
    }
    this.events.length = 0;
    this.waiting = 0;
  }

  private flush(): void {
    while (!this.ended && this.waiting > 0 && this.transport.buffered() < this.limits.highWater) {
      this.transport.write(this.take(), this.taken);
    }
    if (this.ended) return;
    if (this.waiting === 0) {
      if (this.stallTimer) clearTimeout(this.stallTimer);
      this.stallTimer = null;
    } else if (!this.stallTimer) {
      this.progressAt = Date.now();
      this.armStall(this.limits.stallMs);
    }
  }

  private readonly taken = (): void => {
    this.progressAt = Date.now();
    this.flush();
  };

  private armStall(ms: number): void {
    this.stallTimer = setTimeout(() => {
      this.stallTimer = null;
      if (this.ended || this.waiting === 0) return;
      const idle = Date.now() - this.progressAt;
      if (idle >= this.limits.stallMs) {
        this.disconnect(`too slow: ${this.transport.buffered()} bytes unread for ${Math.round(idle / 1000)} s`);
      } else this.armStall(this.limits.stallMs - idle);
    }, ms);
    this.stallTimer.unref();
  }

  private disconnect(reason: string): void {
    warn(`${this.client}: disconnected, ${reason}`);
    this.ended = true;
    this.forget();
    this.clearTimers();
    this.transport.close(reason);
    this.graceTimer = setTimeout(() => this.transport.destroy(), this.limits.closeGraceMs);
    this.graceTimer.unref();
  }

  private clearTimers(): void {
    if (this.stallTimer) clearTimeout(this.stallTimer);
    if (this.graceTimer) clearTimeout(this.graceTimer);
    this.stallTimer = null;
    this.graceTimer = null;
  }
}
