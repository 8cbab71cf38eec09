/**
 * `serve --register <TDD URL>`: the servient registers each served TD into a Thing Description Directory
 * with the TDD HTTP API of W3C WoT Discovery (`PUT <tdd>/things/{id}`, `application/td+json`; 201 created,
 * 204 updated), registers it again when it changes (`calibrate` moves its Cartesian bounds into the real
 * frame), and deregisters it (`DELETE <tdd>/things/{id}`) when the servient stops.
 *
 * A directory that is down or refuses does not stop the twin: each failure is a process warning
 * (`ROBWOT_REGISTER`) naming the directory's answer, and the registration is retried every `RETRY_MS`
 * until it succeeds. Every request is bounded as every outbound one is (`outbound.ts`: deadlines, size cap).
 */
import type { Outbound, OutboundAnswer } from "./outbound.js";

export const RETRY_MS = 10_000;

/** One served Thing as the directory gets it: its id and its current TD. */
export interface Registered {
  id: string;
  td(): unknown;
}

/** The directory's answer in words, for a warning (its body already cut at the outbound size cap). */
function answer(res: OutboundAnswer): string {
  const body = res.body.subarray(0, 300).toString("utf8").replace(/\s+/g, " ");
  return `${res.status} ${res.statusText}${body ? `: ${body}` : ""}`;
}

export class Registrar {
  private readonly retries = new Map<string, NodeJS.Timeout>();
  /** ids the directory has accepted (and that stop() deregisters) */
  private readonly accepted = new Set<string>();
  private readonly inflight = new Set<Promise<void>>();
  private stopped = false;

  /** `tdd`: the directory's base URL (its `/things` is under it), without credentials (`Outbound.authorize`) */
  constructor(
    private readonly outbound: Outbound,
    private readonly tdd: string,
    private readonly things: () => Registered[],
  ) {}

  private thingUrl(id: string): string {
    return `${this.tdd.replace(/\/+$/, "")}/things/${encodeURIComponent(id)}`;
  }

  /** Registers every served Thing (resolves once each has been tried once). */
  async start(): Promise<void> {
    await Promise.all(this.things().map((t) => this.register(t)));
  }

  /** The TD of `id` changed: registers it again. */
  changed(id: string): void {
    const thing = this.things().find((t) => t.id === id);
    if (thing) void this.register(thing);
  }

  private register(thing: Registered): Promise<void> {
    if (this.stopped) return Promise.resolve();
    // stop() waits for registrations in flight, so one it races with is still deregistered
    const p = this.put(thing).finally(() => this.inflight.delete(p));
    this.inflight.add(p);
    return p;
  }

  private async put(thing: Registered): Promise<void> {
    clearTimeout(this.retries.get(thing.id));
    this.retries.delete(thing.id);
    const url = this.thingUrl(thing.id);
    try {
      const res = await this.outbound.request(url, { method: "PUT", headers: { "Content-Type": "application/td+json" }, body: JSON.stringify(thing.td()) });
      if (res.status !== 201 && res.status !== 204 && res.status !== 200) throw new Error(answer(res));
      this.accepted.add(thing.id);
    } catch (err) {
      if (this.stopped) return;
      const why = err instanceof Error ? err.message : String(err);
      process.emitWarning(`robwot serve: registering ${thing.id} at ${url} failed (${why}); retrying in ${RETRY_MS / 1000} s`, { code: "ROBWOT_REGISTER" });
      const timer = setTimeout(() => void this.register(thing), RETRY_MS);
      timer.unref();
      this.retries.set(thing.id, timer);
    }
  }

  /** Stops retrying and deregisters what the directory accepted (each DELETE bounded as every outbound request). */
  async stop(): Promise<void> {
    this.stopped = true;
    for (const t of this.retries.values()) clearTimeout(t);
    this.retries.clear();
    await Promise.all(this.inflight);
    await Promise.all(
      [...this.accepted].map(async (id) => {
        const url = this.thingUrl(id);
        try {
          const res = await this.outbound.request(url, { method: "DELETE" });
          if (res.status !== 204 && res.status !== 200 && res.status !== 404) throw new Error(answer(res));
        } catch (err) {
          process.emitWarning(`robwot serve: deregistering ${id} at ${url} failed (${err instanceof Error ? err.message : String(err)})`, { code: "ROBWOT_REGISTER" });
        }
      }),
    );
    this.accepted.clear();
  }
}
