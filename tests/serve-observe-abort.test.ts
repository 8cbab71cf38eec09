/**
 * End to end: a node-wot long-poll observer that goes away before its answer (a closed tab, a stopped
 * consumer) is unsubscribed. node-wot 0.9.2 only unsubscribes on 'finish', so every later value was
 * piped into the dead response (listener leak: MaxListenersExceededWarning after 11 values).
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, invoke, KUKA_JOINTS, kukaPose, sleep } from "./serve-helpers.js";

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
  for (let i = 0; i < 3; i++) {
    const abort = new AbortController();
    const pending = fetch(`${base}/properties/getJointPosition/observable`, { signal: abort.signal }).catch(() => null);
    await sleep(100);
    abort.abort();
    await pending;
  }
  await sleep(100);
  for (let i = 0; i < 14; i++) {
    const q = KUKA_JOINTS.map((_, k) => (k === 0 ? (i % 2 ? 0.3 : -0.3) : 0));
    const r = await invoke(base, "moveToJointPosition", { joints: kukaPose(q), speed: 1 });
    expect(r.status).toBe(200);
  }
  await sleep(200);
  expect(warnings.filter((w) => w.includes("MaxListeners"))).toEqual([]);
}, 300_000);
