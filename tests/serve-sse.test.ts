/**
 * The WoT Profile's HTTP SSE mechanism: the TD's `subprotocol: "sse"` forms stream an observable property
 * (current value first, then every change) and the collision event, over real HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, sleep } from "./serve-helpers.js";

let s: RunningServient;
let base: string;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  base = s.things[0]!.tdUrl;
}, 300_000);
afterAll(async () => s?.stop());

/** Reads SSE messages from `url` until `until` holds or `ms` pass; returns the parsed `data` fields. */
async function sse(url: string, until: (seen: unknown[]) => boolean, ms: number, during?: () => Promise<void>): Promise<{ type: string | null; data: unknown[] }> {
  const ctl = new AbortController();
  const r = await fetch(url, { signal: ctl.signal });
  const type = r.headers.get("content-type");
  const reader = r.body!.getReader();
  const data: unknown[] = [];
  let text = "";
  const stop = setTimeout(() => ctl.abort(), ms);
  const side = during?.();
  try {
    while (!until(data)) {
      const { value, done } = await reader.read();
      if (done) break;
      text += new TextDecoder().decode(value);
      let end: number;
      while ((end = text.indexOf("\n\n")) >= 0) {
        const block = text.slice(0, end);
        text = text.slice(end + 2);
        const line = block.split("\n").find((l) => l.startsWith("data: "));
        if (line) data.push(JSON.parse(line.slice(6)));
      }
    }
  } catch {
    /* aborted at the deadline: the assertions below say what was missing */
  } finally {
    clearTimeout(stop);
    ctl.abort();
  }
  await side;
  return { type, data };
}

it("declares SSE forms and streams a property: its current value, then every change", async () => {
  const td = (await http(base)).body;
  const form = td.properties.getJointPosition.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse");
  expect(form).toMatchObject({ op: ["observeproperty", "unobserveproperty"] });
  expect(td.events.collision.forms.some((f: { subprotocol?: string }) => f.subprotocol === "sse")).toBe(true);
  const target = kukaPose([0.5, 0, 0, 0, 0, 0, 0]);
  const r = await sse(form.href, (d) => d.length >= 5, 20_000, async () => {
    await sleep(300);
    expect((await invoke(base, "moveToJointPosition", { joints: target, speed: 0.5 })).body.status).toBe("reached");
  });
  expect(r.type).toContain("text/event-stream");
  expect(r.data.length).toBeGreaterThanOrEqual(5);
  expect((r.data[0] as Record<string, number>).lbr_iiwa_joint_1).toBeCloseTo(0, 6);
  const j1 = r.data.map((d) => (d as Record<string, number>).lbr_iiwa_joint_1!);
  expect(Math.max(...j1)).toBeGreaterThan(0);
  for (let i = 1; i < j1.length; i++) expect(j1[i]!).toBeGreaterThanOrEqual(j1[i - 1]! - 1e-9);
});

it("streams the collision event", async () => {
  await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) });
  const href = (await http(base)).body.events.collision.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse").href;
  const r = await sse(href, (d) => d.length >= 1, 30_000, async () => {
    await sleep(300);
    const move = invoke(base, "moveToJointPosition", { joints: kukaPose([0, 1.2, 0, -0.4, 0, 0.4, 0]), speed: 0.05 });
    await sleep(800);
    await invoke(base, "addObstacle", { name: "intruder", shape: { type: "box", size: [0.2, 0.6, 0.2] }, position: [0.55, 0, 0.75] });
    expect((await move).body.status).toBe("collision");
  });
  const ev = r.data[0] as { pair: { a: { body: string }; b: { body: string } } };
  expect([ev.pair.a.body, ev.pair.b.body]).toContain("intruder");
});

it("answers an event stream's headers at once, with a retry line, before any event has happened", async () => {
  const href = (await http(base)).body.events.collision.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse").href;
  const ctl = new AbortController();
  // a stream whose headers wait for the first keep-alive comment (15 s) fails here
  const deadline = setTimeout(() => ctl.abort(), 3000);
  try {
    const r = await fetch(href, { signal: ctl.signal });
    expect(r.status).toBe(200);
    expect(r.headers.get("content-type")).toContain("text/event-stream");
    const first = await r.body!.getReader().read();
    expect(new TextDecoder().decode(first.value)).toMatch(/^retry: \d+\n\n$/);
  } finally {
    clearTimeout(deadline);
    ctl.abort();
  }
});
