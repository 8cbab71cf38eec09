/**
 * The requests the HTTP servers of this process receive (a servient or emulator under test runs in the
 * test's own process): a test waits until the server has a request, not for a time. Node publishes every
 * request on the `http.server.request.start` diagnostics channel as it hands it to the server's handler;
 * what the handler does on it before its first wait on I/O (promise chains included) is done by the next
 * turn of the event loop, which `next` also waits for.
 */
import { subscribe, unsubscribe } from "node:diagnostics_channel";
import type { IncomingMessage } from "node:http";

const CHANNEL = "http.server.request.start";

export class ServerRequests {
  private readonly waiters = new Set<(r: IncomingMessage) => void>();
  private readonly listener = (m: unknown): void => {
    const request = (m as { request: IncomingMessage }).request;
    for (const w of [...this.waiters]) w(request);
  };

  constructor() {
    subscribe(CHANNEL, this.listener);
  }

  /** Resolves once a request matching `match` arrives after this call and the server's handler has run on
   *  it; rejects after `timeoutMs` (a bound on a failure only). */
  next(match: (r: IncomingMessage) => boolean, what: string, timeoutMs = 30_000): Promise<IncomingMessage> {
    return new Promise((resolve, reject) => {
      const timer = setTimeout(() => {
        this.waiters.delete(waiter);
        reject(new Error(`no ${what} reached the server within ${timeoutMs} ms`));
      }, timeoutMs);
      const waiter = (r: IncomingMessage): void => {
        if (!match(r)) return;
        this.waiters.delete(waiter);
        clearTimeout(timer);
        setImmediate(() => resolve(r));
      };
      this.waiters.add(waiter);
    });
  }

  close(): void {
    unsubscribe(CHANNEL, this.listener);
  }
}
