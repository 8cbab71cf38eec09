/**
 * Server-Sent Events for observable properties and events, as the W3C WoT Profile's HTTP SSE mechanism
 * describes them (`subprotocol: "sse"` forms): `GET .../properties/<name>/sse` streams every new value
 * of the property (the current one first), `GET .../events/<name>/sse` every event instance; each message
 * is `event: <name>`, `id: <n>`, `data: <JSON>`. A comment line every 15 s keeps proxies from closing an
 * idle stream. The subscription ends when the client closes the connection.
 */
import type { IncomingMessage, ServerResponse } from "node:http";

/** A source of values: `subscribe` registers a listener and returns the function that removes it. */
export interface SseSource {
  /** the current value, sent first (properties); undefined for events */
  current?: () => unknown;
  subscribe(send: (value: unknown) => void): () => void;
}

const KEEP_ALIVE_MS = 15_000;

export function streamSse(req: IncomingMessage, res: ServerResponse, name: string, source: SseSource): void {
  res.writeHead(200, { "Content-Type": "text/event-stream", "Cache-Control": "no-cache", Connection: "keep-alive" });
  let id = 0;
  const send = (value: unknown): void => {
    if (res.writableEnded) return;
    res.write(`event: ${name}\nid: ${++id}\ndata: ${JSON.stringify(value)}\n\n`);
  };
  if (source.current) send(source.current());
  const unsubscribe = source.subscribe(send);
  const keepAlive = setInterval(() => res.write(": keep-alive\n\n"), KEEP_ALIVE_MS);
  keepAlive.unref();
  const end = (): void => {
    clearInterval(keepAlive);
    unsubscribe();
  };
  req.on("close", end);
  res.on("close", end);
}
