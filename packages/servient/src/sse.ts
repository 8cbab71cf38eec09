/**
 * Server-Sent Events for observable properties and events, as the W3C WoT Profile's HTTP SSE mechanism
 * describes them (`subprotocol: "sse"` forms): `GET .../properties/<name>/sse` streams the new values
 * of the property (the current one first; at most 60 a second, the latest), `GET .../events/<name>/sse` every event instance; each message
 * is `event: <name>`, `id: <n>`, `data: <JSON>`. The headers and a `retry:` line go out at once (an event
 * stream may stay silent for long); a comment line every 15 s keeps proxies from closing an idle stream.
 * The subscription ends when the client closes the connection.
 *
 * Each stream has a `PushQueue` (push-queue.ts): property values coalesce to the latest, event instances
 * are kept up to a bound, and a client that stays behind gets a `: disconnected: <reason>` comment and the
 * end of the response.
 */
import type { IncomingMessage, ServerResponse } from "node:http";
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

type SseItem = { data: string } | { comment: string };

function sseTransport(res: ServerResponse, name: string, ended: () => void): PushTransport<SseItem> {
  let id = 0;
  return {
    buffered: () => res.writableLength,
    write: (item, done) => {
      if (res.writableEnded) return;
      res.write("data" in item ? `event: ${name}\nid: ${++id}\ndata: ${item.data}\n\n` : `: ${item.comment}\n\n`, () => done());
    },
    close: (reason) => {
      ended();
      if (!res.writableEnded) res.end(`: disconnected: ${reason.replace(/[\r\n]/g, " ")}\n\n`);
    },
    destroy: () => res.destroy(),
  };
}

export function streamSse(req: IncomingMessage, res: ServerResponse, name: string, source: SseSource, limits: PushLimits = PUSH_LIMITS): void {
  res.writeHead(200, { "Content-Type": "text/event-stream", "Cache-Control": "no-cache", Connection: "keep-alive" });
  res.write(`retry: ${RETRY_MS}\n\n`);
  let unsubscribe: (() => void) | null = null;
  let ended = false;
  let valueTimer: NodeJS.Timeout | undefined;
  const keepAlive = setInterval(() => queue.push("keep-alive", { comment: "keep-alive" }), KEEP_ALIVE_MS);
  keepAlive.unref();
  /** no more values for this client: it went away, or it was disconnected for being too slow */
  const stop = (): void => {
    if (ended) return;
    ended = true;
    clearInterval(keepAlive);
    clearTimeout(valueTimer);
    unsubscribe?.();
  };
  const peer = `${req.url ?? "sse"} ${req.socket.remoteAddress ?? "?"}:${req.socket.remotePort ?? "?"}`;
  const queue = new PushQueue(sseTransport(res, name, stop), peer, limits);
  // a property's values coalesce (the latest is the value); every event instance counts
  let latest: unknown;
  let valueSentAt = 0;
  const sendValue = (): void => {
    valueTimer = undefined;
    valueSentAt = Date.now();
    queue.push("value", { data: JSON.stringify(latest) });
  };
  const send = source.current
    ? (value: unknown): void => {
        latest = value;
        if (valueTimer) return;
        const wait = VALUE_INTERVAL_MS - (Date.now() - valueSentAt);
        if (wait <= 0) sendValue();
        else valueTimer = setTimeout(sendValue, wait);
      }
    : (value: unknown): void => queue.push(null, { data: JSON.stringify(value) });
  if (source.current) send(source.current());
  if (!ended) unsubscribe = source.subscribe(send);
  const gone = (): void => {
    stop();
    queue.dispose();
  };
  req.on("close", gone);
  res.on("close", gone);
}
