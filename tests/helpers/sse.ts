/**
 * A raw Server-Sent Events client over fetch for the tests: every field of every message as the server
 * sent it (event, id, data, retry, comments), `Last-Event-ID` as a header, waits on what arrived.
 */

export interface SseMessage {
  event: string | null;
  id: string | null;
  data: string | null;
  retry: number | null;
  comment: string | null;
}

export interface SseStream {
  status: number;
  headers: Headers;
  /** every message so far, in order */
  messages: SseMessage[];
  /** the messages with data (events), parsed */
  events(): { event: string | null; id: string | null; data: any }[];
  /** resolves once `until(messages)` holds; rejects after `ms` (a bound on a failure only) */
  wait(until: (m: SseMessage[]) => boolean, ms?: number): Promise<void>;
  close(): void;
}

function parse(block: string): SseMessage {
  const m: SseMessage = { event: null, id: null, data: null, retry: null, comment: null };
  for (const line of block.split("\n")) {
    if (line.startsWith(":")) {
      m.comment = line.slice(1).trim();
      continue;
    }
    const colon = line.indexOf(":");
    const field = colon < 0 ? line : line.slice(0, colon);
    const value = colon < 0 ? "" : line.slice(colon + 1).replace(/^ /, "");
    if (field === "event") m.event = value;
    else if (field === "id") m.id = value;
    else if (field === "data") m.data = m.data === null ? value : `${m.data}\n${value}`;
    else if (field === "retry") m.retry = Number(value);
  }
  return m;
}

export async function openSse(url: string, headers: Record<string, string> = {}): Promise<SseStream> {
  const ctl = new AbortController();
  const r = await fetch(url, { headers: { accept: "text/event-stream", ...headers }, signal: ctl.signal });
  const messages: SseMessage[] = [];
  const waiters = new Set<() => void>();
  let ended = false;
  const reader = r.body!.getReader();
  void (async () => {
    let text = "";
    try {
      for (;;) {
        const { value, done } = await reader.read();
        if (done) break;
        text += new TextDecoder().decode(value);
        let end: number;
        while ((end = text.indexOf("\n\n")) >= 0) {
          messages.push(parse(text.slice(0, end)));
          text = text.slice(end + 2);
        }
        for (const w of waiters) w();
      }
    } catch {
      /* closed by the test */
    } finally {
      ended = true;
      for (const w of waiters) w();
    }
  })();
  return {
    status: r.status,
    headers: r.headers,
    messages,
    events: () => messages.filter((m) => m.data !== null).map((m) => ({ event: m.event, id: m.id, data: JSON.parse(m.data!) })),
    wait: (until, ms = 30_000) =>
      new Promise<void>((resolve, reject) => {
        const check = (): void => {
          if (until(messages)) done(resolve);
          else if (ended) done(() => reject(new Error(`stream ended; got ${JSON.stringify(messages).slice(0, 500)}`)));
        };
        const timer = setTimeout(() => done(() => reject(new Error(`not within ${ms} ms; got ${JSON.stringify(messages).slice(0, 500)}`))), ms);
        const done = (f: () => void): void => {
          clearTimeout(timer);
          waiters.delete(check);
          f();
        };
        waiters.add(check);
        check();
      }),
    close: () => ctl.abort(),
  };
}
