/** The heartbeat every backend supervisor uses, against a real backend process stopped with SIGSTOP. */
import { afterAll, describe, expect, it } from "vitest";
import { launchBackend, startHeartbeat, type LaunchedBackend } from "./index.js";

const started: LaunchedBackend[] = [];
afterAll(async () => {
  for (const b of started) {
    try {
      process.kill(b.pid!, "SIGCONT");
    } catch {
      // already gone: nothing to resume
    }
    await b.stop();
  }
});

describe("startHeartbeat", () => {
  it("stays quiet while the backend answers, reports it dead once when it stops answering", async () => {
    const backend = await launchBackend();
    started.push(backend);
    // a deadline no answering backend misses on a loaded machine; what is tested is the missed one
    const PERIOD_MS = 100;
    const DEAD_AFTER_MS = 3_000;
    const deaths: string[] = [];
    let sent = 0;
    let answered = 0;
    const until = async (what: string, done: () => boolean): Promise<void> => {
      for (const end = Date.now() + 30_000; !done(); await new Promise((r) => setTimeout(r, 20))) {
        if (Date.now() > end) throw new Error(`${what}: not within 30 s (deaths: ${JSON.stringify(deaths)})`);
      }
    };
    const ping = async (o: { timeoutMs: number }): Promise<unknown> => {
      sent++;
      const r = await backend.client.ping({}, o);
      answered++;
      return r;
    };
    const stop = startHeartbeat(ping, { periodMs: PERIOD_MS, deadAfterMs: DEAD_AFTER_MS }, (reason) => deaths.push(reason));
    // ten pings answered: a late one would have been reported at its deadline, before its answer
    await until("ten answered pings", () => answered >= 10);
    expect(deaths).toEqual([]);
    process.kill(backend.pid!, "SIGSTOP");
    await until("the report", () => deaths.length > 0);
    // once: no ping after the report. The marker: two ticks of a timer of the heartbeat's period started
    // after the report, so the heartbeat's own timer has ticked since
    const pings = sent;
    await new Promise<void>((resolve) => {
      let ticks = 0;
      const marker = setInterval(() => {
        if (++ticks < 2) return;
        clearInterval(marker);
        resolve();
      }, PERIOD_MS);
    });
    stop();
    expect(sent).toBe(pings);
    expect(deaths).toEqual([`no answer to ping within ${DEAD_AFTER_MS} ms`]);
  }, 60_000);
});
