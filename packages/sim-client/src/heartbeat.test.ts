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
    const deaths: { reason: string; at: number }[] = [];
    const stop = startHeartbeat((o) => backend.client.ping({}, o), { periodMs: 100, deadAfterMs: 800 }, (reason) =>
      deaths.push({ reason, at: Date.now() }),
    );
    await new Promise((r) => setTimeout(r, 1_500));
    expect(deaths).toEqual([]);
    const stoppedAt = Date.now();
    process.kill(backend.pid!, "SIGSTOP");
    await new Promise((r) => setTimeout(r, 2_500));
    stop();
    expect(deaths).toHaveLength(1);
    expect(deaths[0]!.reason).toBe("no answer to ping within 800 ms");
    // the first ping after the stop misses its deadline: dead within one period plus the deadline (and slack)
    expect(deaths[0]!.at - stoppedAt).toBeLessThan(800 + 100 + 600);
  }, 30_000);
});
