/**
 * Backend restart edges: a restore that hangs after a restart is bounded (the heartbeat watches it, and a
 * restart's restore as a whole has a deadline), and a failed restart reaches motionStatus.lastError and
 * the log. The backend is real; between it and the servient runs a WebSocket relay that can make one
 * connection hang from a chosen method on (it forwards nothing more either way, like a stopped process),
 * or swallow just that request (a backend that answers pings but never finishes it).
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import WebSocket, { WebSocketServer } from "ws";
import { launchBackend, type LaunchedBackend } from "../packages/sim-client/src/index.js";
import { BackendSupervisor, urlConnector } from "@robwot/sim-client";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, waitFor } from "./serve-helpers.js";

interface HangingRelay {
  url: string;
  /** connections accepted so far */
  connections: number;
  /** the `n`th connection hangs from its first request of `method` on (`only`: just that request is lost) */
  hangAt(n: number, method: string, only?: boolean): void;
  /** closes every open connection (the servient sees its backend gone) */
  drop(): void;
  close(): Promise<void>;
}

async function hangingRelay(backend: LaunchedBackend): Promise<HangingRelay> {
  const wss = new WebSocketServer({ host: "127.0.0.1", port: 0 });
  await new Promise((r) => wss.once("listening", r));
  let rule: { n: number; method: string; only: boolean } | null = null;
  const open = new Set<WebSocket>();
  const relay: HangingRelay = {
    url: `ws://127.0.0.1:${(wss.address() as { port: number }).port}`,
    connections: 0,
    hangAt: (n, method, only = false) => (rule = { n, method, only }),
    drop: () => open.forEach((c) => c.terminate()),
    close: () => {
      open.forEach((c) => c.terminate());
      return new Promise((r) => wss.close(() => r()));
    },
  };
  wss.on("connection", (client) => {
    const n = ++relay.connections;
    open.add(client);
    const up = new WebSocket(backend.url, { headers: { Authorization: `Bearer ${backend.token}` } });
    const waiting: string[] = [];
    let hung = false;
    up.on("open", () => waiting.splice(0).forEach((m) => up.send(m)));
    client.on("message", (data) => {
      const text = data.toString();
      if (!hung && rule?.n === n && (JSON.parse(text) as { method?: string }).method === rule.method) {
        if (rule.only) return;
        hung = true;
      }
      if (hung) return;
      if (up.readyState === WebSocket.OPEN) up.send(text);
      else waiting.push(text);
    });
    up.on("message", (data) => {
      if (!hung) client.send(data.toString());
    });
    client.on("close", () => {
      open.delete(client);
      up.close();
    });
    up.on("close", () => client.terminate());
    up.on("error", () => client.terminate());
  });
  return relay;
}

let backend: LaunchedBackend;
let relay: HangingRelay;

beforeAll(async () => {
  backend = await launchBackend();
  relay = await hangingRelay(backend);
});
afterAll(async () => {
  await relay?.close();
  await backend?.stop();
});

it("a backend that hangs while the world is restored after a restart is replaced; the failed restart is reported", async () => {
  const s: RunningServient = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, backendUrl: relay.url });
  const warnings: string[] = [];
  const onWarning = (w: Error & { code?: string }): void => void (w.code === "ROBWOT_BACKEND_RESTART" && warnings.push(w.message));
  process.on("warning", onWarning);
  try {
    const twin = [...s.twins.values()][0]!;
    const errors: string[] = [];
    twin.on("status", (st) => st.lastError && errors.push(`${st.lastError.code}: ${st.lastError.message}`));
    // the first restart (connection 2) hangs at robot.load: a long method, sent without a request deadline
    relay.hangAt(relay.connections + 1, "robot.load");
    relay.drop();
    await waitFor(() => s.backend.restarts >= 1, { timeoutMs: 60_000, what: "a restart" }).catch((e: Error) => {
      throw new Error(`${e.message}; lastError: ${errors.at(-1)}`);
    });
    // declared dead by the heartbeat (a ping unanswered), then the next attempt restores the world
    const failed = errors.find((e) => /restart 1 failed/.test(e));
    expect(failed).toMatch(/^E_BACKEND_DOWN: simulation backend restart 1 failed \(backend declared dead while restoring the world \(no answer to ping/);
    expect(warnings.some((w) => /restart 1 failed/.test(w))).toBe(true);
    expect(twin.status.lastError?.code).toBe("E_BACKEND_RESTARTED");
  } finally {
    process.off("warning", onWarning);
    await s.stop();
  }
});

it("a restart's restore that answers pings but never ends is bounded by restoreMs", async () => {
  const failures: string[] = [];
  let restores = 0;
  const sup = new BackendSupervisor(
    urlConnector(relay.url),
    async (sim) => {
      restores++;
      await sim.loadScene({ scene: { version: 1, obstacles: [] } });
    },
    { retryDelayMs: 50, deadlines: { heartbeatMs: 200, deadAfterMs: 1_000, restoreMs: 2_000 } },
  );
  sup.on("restartFailed", (err) => failures.push(err.message));
  await sup.start();
  try {
    // the first restart's world.loadScene (a long method) gets no answer, while pings still do
    relay.hangAt(relay.connections + 1, "world.loadScene", true);
    const pingsPass = relay.connections + 1;
    relay.drop();
    await waitFor(() => sup.restarts >= 1, { what: "a restart" }).catch((e: Error) => {
      throw new Error(`${e.message} (${restores} restores, failures: ${failures.join("; ")})`);
    });
    expect(relay.connections).toBeGreaterThan(pingsPass);
    // ended by restoreMs while its pings were answered, not by the heartbeat
    expect(failures[0]).toMatch(/backend declared dead while restoring the world \(restore not finished within 2000 ms\)/);
  } finally {
    await sup.stop();
  }
});
