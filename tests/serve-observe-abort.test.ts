/**
 * End to end: a node-wot long-poll observer that goes away before its answer (a closed tab, a stopped
 * consumer) is unsubscribed. node-wot 0.9.2 only unsubscribes on 'finish', so every later value was
 * piped into the dead response (listener leak: MaxListenersExceededWarning after 11 values).
 */
import type { IncomingMessage } from "node:http";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { ServerRequests } from "./helpers/server-requests.js";
import { generateTwin, invoke, KUKA_JOINTS, kukaPose } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
const warnings: string[] = [];
const onWarning = (w: Error): void => void warnings.push(`${w.name}: ${w.message}`);
beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 500)], port: 0, realtime: 0 });
  base = `${s.url}/${s.things[0]!.slug}`;
  process.on("warning", onWarning);
});
afterAll(async () => {
  process.off("warning", onWarning);
  await s?.stop();
});

it("an aborted long-poll observation leaves no listener behind", async () => {
  const requests = new ServerRequests();
  const observe = `${base}/properties/getJointPosition/observable`;
  const isObserve = (r: IncomingMessage): boolean => r.url?.endsWith("/properties/getJointPosition/observable") ?? false;
  const move = async (i: number): Promise<void> => {
    const q = KUKA_JOINTS.map((_, k) => (k === 0 ? (i % 2 ? 0.3 : -0.3) : 0));
    expect((await invoke(base, "moveToJointPosition", { joints: kukaPose(q), speed: 1 })).status).toBe(200);
  };
  try {
    for (let i = 0; i < 3; i++) {
      const abort = new AbortController();
      const pending = fetch(observe, { signal: abort.signal }).catch(() => null);
      // aborted once the servient holds it (its observer subscribed)
      await requests.next(isObserve, "long-poll observation");
      abort.abort();
      await pending;
    }
    // past the 11 values that made node-wot warn when the aborted observers stayed subscribed
    for (let i = 0; i < 14; i++) await move(i);
    // the marker: an observer subscribed now is answered with the next value, which every observer still
    // subscribed (the aborted ones, had they stayed) was handed in the same notification
    const watching = fetch(observe);
    await requests.next(isObserve, "the last observation");
    await move(14);
    expect((await watching).status).toBe(200);
    expect(warnings.filter((w) => w.includes("MaxListeners"))).toEqual([]);
  } finally {
    requests.close();
  }
}, 300_000);
