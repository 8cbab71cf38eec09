/**
 * Server-Sent Events for observable properties and events, as the W3C WoT Profile's HTTP SSE Profile
 * describes them (`subprotocol: "sse"` forms): `GET .../properties/<name>/sse` streams the new values
 * of the property (the current one first; at most 60 a second, the latest), `GET .../events/<name>/sse`
 * every event instance; each message is `event: <name>`, `id: <n>`, `data: <JSON>`. The headers and a
 * `retry:` line go out at once (an event stream may stay silent for long); a comment line every 15 s
 * keeps proxies from closing an idle stream. The subscription ends when the client closes the connection.
 *
 * Resuming (`SseChannel`, one per Thing and stream, shared by its clients):
 * - ids are integers, increasing per Thing and stream across connections and across restarts of the
 *   servient (`event-history.ts`).
 * - an event stream keeps its last `EVENT_HISTORY` instances: a request with `Last-Event-ID: n` (what an
 *   EventSource sends when it reconnects) gets every kept instance after n first, then the live ones.
 * - when instances after n are no longer known (the history overflowed, or n is of an earlier run of the
 *   servient), the stream says so before the replay with one message `event: robwot:gap` (no id) whose
 *   data is `{lastEventId, firstKept, reason: "overflow" | "restart"}`: a missed event is never silent.
 * - a property stream is a state: a resumed one starts with the current value, as a new one does.
 *
 * Each client has a `PushQueue` (push-queue.ts): property values coalesce to the latest, event instances
 * are kept up to a bound, and a client that stays behind gets a `: disconnected: <reason>` comment and the
 * end of the response (it then resumes from the last id it received).
 */
import type { IncomingMessage, ServerResponse } from "node:http";
import { EventHistory, resumePoint, Sequence, type Gap } from "./event-history.js";
import { PUSH_LIMITS, PushQueue, type PushLimits, type PushTransport } from "./push-queue.js";

/** A source of values: `subscribe` registers a listener and returns the function that removes it. */
export interface SseSource {
  /** the current value, sent first (properties); undefined for events */
  current?: () => unknown;
  subscribe(send: (value: unknown) => void): () => void;
}

const KEEP_ALIVE_MS = 15_000;
/** the reconnection delay the stream asks of an EventSource */
const RETRY_MS = 3000;
/** a property's values are sent at most this often, the latest (each costs every stream a write) */
const VALUE_INTERVAL_MS = 1000 / 60;
/** the event name of the notice that instances were missed (not an affordance: beyond the Profile) */
export const GAP_EVENT = "robwot:gap";

interface SseMessage {
  id: number;
  data: string;
}

interface Listener {
  message(m: SseMessage): void;
}

/**
 * One stream (a property's values or an event's instances) of one Thing for all its SSE clients: the ids,
 * the history of an event, the coalescing of a property's values (one serialisation per value, not one
 * per client). An event channel listens to its source from its creation on, so instances are recorded
 * while no client is connected; a property channel only while it has clients. It lives as long as the
 * Thing it listens to.
 */
export class SseChannel {
  private readonly ids: EventHistory<SseMessage>;
  private readonly listeners = new Set<Listener>();
  private unsubscribe: (() => void) | null = null;
  private latest: unknown;
  private valueTimer: NodeJS.Timeout | undefined;
  private valueSentAt = 0;

  constructor(
    readonly name: string,
    private readonly source: SseSource,
    now = Date.now(),
  ) {
    this.ids = new EventHistory(new Sequence(now));
    if (!this.isProperty) this.unsubscribe = source.subscribe((v) => this.record(v));
  }

  get isProperty(): boolean {
    return this.source.current !== undefined;
  }

  /** Event instances a client that last saw `lastEventId` missed, and the gap when some are lost. */
  missed(lastEventId: number): { replay: SseMessage[]; gap: Gap | null } {
    return this.ids.since(lastEventId);
  }

  /** Adds a client; returns the function that removes it. A property's current value goes to it first. */
  attach(listener: Listener): () => void {
    this.listeners.add(listener);
    if (this.isProperty) {
      listener.message({ id: this.ids.numbers.take(), data: JSON.stringify(this.source.current!()) });
      this.unsubscribe ??= this.source.subscribe((v) => this.value(v));
    }
    return () => {
      this.listeners.delete(listener);
      if (this.isProperty && this.listeners.size === 0) this.stopValues();
    };
  }

  private stopValues(): void {
    this.unsubscribe?.();
    this.unsubscribe = null;
    clearTimeout(this.valueTimer);
    this.valueTimer = undefined;
  }

  private record(value: unknown): void {
    const m = this.ids.record((id) => ({ id, data: JSON.stringify(value) }));
    for (const l of this.listeners) l.message(m);
  }

  /** a property's values coalesce (the latest is the value): at most one per VALUE_INTERVAL_MS */
  private value(v: unknown): void {
    this.latest = v;
    if (this.valueTimer) return;
    const wait = VALUE_INTERVAL_MS - (Date.now() - this.valueSentAt);
    if (wait <= 0) this.sendValue();
    else this.valueTimer = setTimeout(() => this.sendValue(), wait);
  }

  private sendValue(): void {
    this.valueTimer = undefined;
    this.valueSentAt = Date.now();
    const m = { id: this.ids.numbers.take(), data: JSON.stringify(this.latest) };
    for (const l of this.listeners) l.message(m);
  }
}

type SseItem = { message: SseMessage } | { gap: Gap } | { comment: string };

function sseTransport(res: ServerResponse, name: string, ended: () => void): PushTransport<SseItem> {
  return {
    buffered: () => res.writableLength,
    write: (item, done) => {
      if (res.writableEnded) return;
      let text: string;
      if ("message" in item) text = `event: ${name}\nid: ${item.message.id}\ndata: ${item.message.data}\n\n`;
      else if ("gap" in item) {
        const { lastSeen, firstKept, reason } = item.gap;
        const data = JSON.stringify({ lastEventId: lastSeen, firstKept, reason });
        text = `event: ${GAP_EVENT}\ndata: ${data}\n\n`;
      }
      else text = `: ${item.comment}\n\n`;
      res.write(text, () => done());
    },
    close: (reason) => {
      ended();
      if (!res.writableEnded) res.end(`: disconnected: ${reason.replace(/[\r\n]/g, " ")}\n\n`);
    },
    destroy: () => res.destroy(),
  };
}

export function streamSse(
  req: IncomingMessage,
  res: ServerResponse,
  channel: SseChannel,
  limits: PushLimits = PUSH_LIMITS,
): void {
  const headers = { "Content-Type": "text/event-stream", "Cache-Control": "no-cache", Connection: "keep-alive" };
  res.writeHead(200, headers);
  res.write(`retry: ${RETRY_MS}\n\n`);
  let detach: (() => void) | null = null;
  let ended = false;
  const keepAlive = setInterval(() => queue.push("keep-alive", { comment: "keep-alive" }), KEEP_ALIVE_MS);
  keepAlive.unref();
  /** no more values for this client: it went away, or it was disconnected for being too slow */
  const stop = (): void => {
    if (ended) return;
    ended = true;
    clearInterval(keepAlive);
    detach?.();
  };
  const peer = `${req.url ?? "sse"} ${req.socket.remoteAddress ?? "?"}:${req.socket.remotePort ?? "?"}`;
  const queue = new PushQueue(sseTransport(res, channel.name, stop), peer, limits);
  const key = channel.isProperty ? "value" : null;
  const last = resumePoint(req.headers["last-event-id"]);
  if (last !== null && !channel.isProperty) {
    // replayed and live instances cannot interleave: both are pushed on this one turn of the event loop
    const { replay, gap } = channel.missed(last);
    if (gap) queue.push(null, { gap });
    for (const message of replay) queue.push(null, { message });
  }
  if (!ended) detach = channel.attach({ message: (message) => queue.push(key, { message }) });
  // disconnected by the first message already (stop ran before there was anything to detach)
  if (ended) detach?.();
  const gone = (): void => {
    stop();
    queue.dispose();
  };
  req.on("close", gone);
  res.on("close", gone);
}
