/**
 * The WoT Profile's HTTP SSE mechanism: the TD's `subprotocol: "sse"` forms stream an observable property
 * (current value first, then every change) and the collision event, over real HTTP. Streams resume: ids
 * increase per Thing and stream across connections (and restarts), `Last-Event-ID` replays the events
 * missed, a gap the history no longer covers is announced (`robwot:gap`); `/live` resumes by `seq` the
 * same way. Clients: raw fetch (every field), the `ws` WebSocket, and Chromium's EventSource across a
 * restart of the servient.
 */
import type { IncomingMessage } from "node:http";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { openBrowser } from "./helpers/browser.js";
import { ServerRequests } from "./helpers/server-requests.js";
import { openSse } from "./helpers/sse.js";
import { consumer, generateTwin, http, invoke, kukaPose, live, waitFor, waitMoved } from "./serve-helpers.js";

let s: RunningServient;
let base: string;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  base = s.things[0]!.tdUrl;
}, 300_000);
afterAll(async () => s?.stop());

it("declares SSE forms and streams a property: its current value, then every change", async () => {
  const td = (await http(base)).body;
  const form = td.properties.getJointPosition.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse");
  expect(form).toMatchObject({ op: ["observeproperty", "unobserveproperty"] });
  expect(td.events.collision.forms.some((f: { subprotocol?: string }) => f.subprotocol === "sse")).toBe(true);
  const target = kukaPose([0.5, 0, 0, 0, 0, 0, 0]);
  const stream = await openSse(form.href);
  const values = (): Record<string, number>[] => stream.events().map((e) => e.data);
  try {
    // the current value first, then the move
    await stream.wait(() => values().length >= 1);
    expect((await invoke(base, "moveToJointPosition", { joints: target, speed: 0.5 })).body.status).toBe("reached");
    await stream.wait(() => values().length >= 5);
  } finally {
    stream.close();
  }
  expect(stream.headers.get("content-type")).toContain("text/event-stream");
  expect(values()[0]!.lbr_iiwa_joint_1).toBeCloseTo(0, 6);
  const j1 = values().map((d) => d.lbr_iiwa_joint_1!);
  expect(Math.max(...j1)).toBeGreaterThan(0);
  for (let i = 1; i < j1.length; i++) expect(j1[i]!).toBeGreaterThanOrEqual(j1[i - 1]! - 1e-9);
});

it("streams the collision event", async () => {
  await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) });
  const href = (await http(base)).body.events.collision.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse").href;
  // subscribed once its headers are in (the server answers them as it attaches the stream)
  const stream = await openSse(href);
  try {
    const move = invoke(base, "moveToJointPosition", { joints: kukaPose([0, 1.2, 0, -0.4, 0, 0.4, 0]), speed: 0.05 });
    // the obstacle comes into the path of the running motion
    await waitMoved(base, "lbr_iiwa_joint_2", 0);
    await invoke(base, "addObstacle", { name: "intruder", shape: { type: "box", size: [0.2, 0.6, 0.2] }, position: [0.55, 0, 0.75] });
    expect((await move).body.status).toBe("collision");
    await stream.wait((m) => m.some((x) => x.data !== null));
  } finally {
    stream.close();
  }
  const ev = stream.events()[0]!.data as { pair: { a: { body: string }; b: { body: string } } };
  expect([ev.pair.a.body, ev.pair.b.body]).toContain("intruder");
});

it("answers an event stream's headers at once, with a retry line, before any event has happened", async () => {
  const href = (await http(base)).body.events.collision.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse").href;
  const ctl = new AbortController();
  try {
    const r = await fetch(href, { signal: ctl.signal });
    expect(r.status).toBe(200);
    expect(r.headers.get("content-type")).toContain("text/event-stream");
    // the retry line alone: a stream whose headers waited for the first keep-alive comment (15 s) would
    // start with that comment
    const first = await r.body!.getReader().read();
    expect(new TextDecoder().decode(first.value)).toMatch(/^retry: \d+\n\n$/);
  } finally {
    ctl.abort();
  }
});

describe("resuming", () => {
  let twin: import("node:events").EventEmitter;
  let eventHref: string;
  // synthetic instances in the twin's own emitter: what is tested here is their way to the clients
  const collide = (n: number): void => void twin.emit("collision", { pair: { a: { body: "robot" }, b: { body: `test-${n}` } }, n });
  const ids = (stream: { events(): { id: string | null }[] }): number[] => stream.events().map((e) => Number(e.id));

  beforeAll(async () => {
    twin = s.twins.values().next().value!;
    eventHref = (await http(base)).body.events.collision.forms.find((f: { subprotocol?: string }) => f.subprotocol === "sse").href;
  });

  it("a property stream's ids increase across connections", async () => {
    const href = `${base}/properties/motionStatus/sse`;
    const a = await openSse(href);
    await a.wait((m) => m.some((x) => x.data !== null));
    a.close();
    const b = await openSse(href, { "last-event-id": a.events()[0]!.id! });
    await b.wait((m) => m.some((x) => x.data !== null));
    b.close();
    expect(ids(b)[0]).toBeGreaterThan(ids(a)[0]!);
    // a property is a state: a resumed stream starts with the current value, nothing replayed, no gap
    expect(b.events().map((e) => e.event)).toEqual(["motionStatus"]);
  });

  it("Last-Event-ID replays the events missed while disconnected, in order, then the live ones", async () => {
    const a = await openSse(eventHref);
    collide(1);
    await a.wait((m) => m.some((x) => x.data !== null));
    // what `a` has not seen is missed, whether or not the server has noticed the close yet
    a.close();
    collide(2);
    collide(3);
    const last = a.events().at(-1)!.id!;
    const b = await openSse(eventHref, { "last-event-id": last });
    expect(b.status).toBe(200);
    await b.wait((m) => m.filter((x) => x.data !== null).length >= 2);
    collide(4);
    await b.wait((m) => m.filter((x) => x.data !== null).length >= 3);
    b.close();
    expect(b.events().map((e) => e.data.n)).toEqual([2, 3, 4]);
    expect(b.messages.some((m) => m.event === "robwot:gap")).toBe(false);
    const all = [...ids(a), ...ids(b)];
    for (let i = 1; i < all.length; i++) expect(all[i]).toBe(all[i - 1]! + 1);
    // a new client without Last-Event-ID gets only what happens from now on
    const c = await openSse(eventHref);
    collide(5);
    await c.wait((m) => m.some((x) => x.data !== null));
    c.close();
    expect(c.events().map((e) => e.data.n)).toEqual([5]);
  });

  it("a gap older than the history is announced (robwot:gap, overflow), then the kept events follow", async () => {
    const a = await openSse(eventHref);
    collide(100);
    await a.wait((m) => m.some((x) => x.data !== null));
    a.close();
    for (let i = 101; i <= 200; i++) collide(i);
    const b = await openSse(eventHref, { "last-event-id": a.events()[0]!.id! });
    await b.wait((m) => m.filter((x) => x.data !== null).length >= 64);
    b.close();
    const [gap, ...rest] = b.events();
    expect(gap!.event).toBe("robwot:gap");
    expect(gap!.id).toBeNull();
    expect(gap!.data).toMatchObject({ lastEventId: Number(a.events()[0]!.id), reason: "overflow" });
    // the history keeps the last 63: 138..200
    expect(rest.map((e) => e.data.n)).toEqual(Array.from({ length: 63 }, (_, i) => 138 + i));
    expect(Number(rest[0]!.id)).toBe(gap!.data.firstKept);
  });

  it("a Last-Event-ID of an earlier run of the servient: robwot:gap with reason restart", async () => {
    const b = await openSse(eventHref, { "last-event-id": "1" });
    await b.wait((m) => m.some((x) => x.data !== null));
    b.close();
    expect(b.events()[0]).toMatchObject({ event: "robwot:gap", data: { lastEventId: 1, reason: "restart" } });
  });

  it("node-wot 0.9.2 receives events over the first (long-poll) form and nothing over the sse form (README: why)", async () => {
    const c = await consumer();
    const subscriptions: { stop(): Promise<void> }[] = [];
    const requests = new ServerRequests();
    const path = (r: IncomingMessage): string => (r.url ?? "").split("?")[0]!;
    const isPoll = (r: IncomingMessage): boolean => path(r).endsWith("/events/collision");
    try {
      const td = (await http(base)).body;
      const sseForm = td.events.collision.forms.findIndex((f: { subprotocol?: string }) => f.subprotocol === "sse");
      expect(sseForm).toBeGreaterThan(0);
      const got: Record<"longpoll" | "sse", unknown[]> = { longpoll: [], sse: [] };
      const subscribed = Promise.all([requests.next(isPoll, "node-wot's long poll"), requests.next((r) => path(r).endsWith("/events/collision/sse"), "node-wot's SSE stream")]);
      // one ConsumedThing per subscription (node-wot keeps one per event name); the body read as bytes:
      // value() would check the synthetic instance against the event's schema
      for (const [via, options] of [["longpoll", undefined], ["sse", { formIndex: sseForm }]] as const) {
        const thing = await c.wot.consume(td);
        const listener = async (out: WoT.InteractionOutput): Promise<void> => void got[via].push(JSON.parse(Buffer.from(await out.arrayBuffer()).toString()));
        subscriptions.push(await thing.subscribeEvent("collision", listener, undefined, options));
      }
      await subscribed;
      const repolled = requests.next(isPoll, "node-wot's next long poll");
      collide(400);
      await waitFor(() => got.longpoll.length >= 1, { what: "the event over long poll" });
      // the marker: a second event, over the long poll node-wot sent after the first; the first reached its
      // SSE stream a whole round trip before
      await repolled;
      collide(401);
      await waitFor(() => got.longpoll.length >= 2, { what: "the second event over long poll" });
      expect(got.longpoll).toEqual([expect.objectContaining({ n: 400 }), expect.objectContaining({ n: 401 })]);
      // its SSE client listens to unnamed messages only; the Profile's messages are named (event: collision)
      expect(got.sse).toEqual([]);
    } finally {
      requests.close();
      for (const sub of subscriptions) await sub.stop().catch(() => undefined);
      await c.stop();
    }
  });

  it("/live: every stream message has a seq; resume=<seq> replays the missed events before the snapshot", async () => {
    const slug = s.things[0]!.slug;
    const a = await live(`${s.liveUrl}?thing=${slug}`);
    collide(300);
    const seen = await a.waitFor((m) => m.type === "collision" && m.n === 300);
    a.close();
    for (const m of a.messages) expect(m.seq, JSON.stringify(m)).toBeTypeOf("number");
    const seqs = a.messages.map((m) => m.seq as number);
    for (let i = 1; i < seqs.length; i++) expect(seqs[i]).toBeGreaterThan(seqs[i - 1]!);
    collide(301);
    collide(302);
    const b = await live(`${s.liveUrl}?thing=${slug}&resume=${seen.seq}`);
    await b.waitFor((m) => m.type === "scene");
    b.close();
    expect(b.messages.slice(0, 2).map((m) => [m.type, m.n])).toEqual([["collision", 301], ["collision", 302]]);
    expect(b.messages.slice(2).map((m) => m.type).sort()).toEqual(["joints", "scene", "status"]);
    const later = b.messages.map((m) => m.seq as number);
    expect(later[0]).toBeGreaterThan(seen.seq);
    for (let i = 1; i < later.length; i++) expect(later[i]).toBeGreaterThan(later[i - 1]!);
    // resuming by message, and from a seq the history no longer covers
    const c = await live(s.liveUrl);
    c.ws.send(JSON.stringify({ subscribe: slug, resume: 5 }));
    const gap = await c.waitFor((m) => m.type === "gap");
    await c.waitFor((m) => m.type === "scene");
    c.close();
    expect(gap).toMatchObject({ thing: slug, resume: 5, reason: "restart" });
    expect(gap.seq).toBeUndefined();
    expect(c.messages[0]).toBe(gap);
    // a resume point that is not a seq is refused (subscribing without it would lose events silently)
    const d = await live(s.liveUrl);
    for (const resume of [{ x: 1 }, "12abc", -3]) d.ws.send(JSON.stringify({ subscribe: slug, resume }));
    d.ws.send(JSON.stringify({ subscribe: slug }));
    await d.waitFor((m) => m.type === "scene");
    d.close();
    expect(d.messages.slice(0, 3).map((m) => [m.type, m.code])).toEqual(Array(3).fill(["error", "E_BAD_MESSAGE"]));
    expect(d.messages.slice(3).map((m) => m.type).sort()).toEqual(["joints", "scene", "status"]);
  });
});

it("Chromium's EventSource resumes across a restart of the servient: told of the gap, ids keep increasing", async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  let a: RunningServient | null = await startServient({ twins: [dir], port: 0, realtime: 1 });
  const port = Number(new URL(a.url).port);
  const href = `${a.things[0]!.tdUrl}/events/collision/sse`;
  const browser = await openBrowser();
  let b: RunningServient | null = null;
  try {
    await browser.page.goto(`${a.url}/robwot.json`);
    await browser.page.evaluate((url) => {
      const w = window as unknown as { got: unknown[]; es: EventSource };
      w.got = [];
      w.es = new EventSource(url);
      w.es.addEventListener("collision", (e) => w.got.push({ event: "collision", id: e.lastEventId, data: JSON.parse(e.data) }));
      w.es.addEventListener("robwot:gap", (e) => w.got.push({ event: "gap", id: e.lastEventId, data: JSON.parse(e.data) }));
    }, href);
    const got = (): Promise<any[]> => browser.page.evaluate(() => (window as unknown as { got: unknown[] }).got);
    const twinA = a.twins.values().next().value!;
    // open: the server has attached the stream
    await browser.page.waitForFunction(() => (window as unknown as { es: EventSource }).es.readyState === EventSource.OPEN);
    // synthetic instances (as in "resuming"): what is tested is their way to the browser
    twinA.emit("collision", { n: 1 } as never);
    await browser.page.waitForFunction(() => (window as unknown as { got: unknown[] }).got.length >= 1);
    await a.stop();
    a = null;
    b = await startServient({ twins: [dir], port, realtime: 1 });
    // the EventSource reconnects on its own (retry: 3000) with the last id it saw
    await browser.page.waitForFunction(() => (window as unknown as { got: unknown[] }).got.length >= 2);
    b.twins.values().next().value!.emit("collision", { n: 2 } as never);
    await browser.page.waitForFunction(() => (window as unknown as { got: unknown[] }).got.length >= 3);
    const [first, gap, second] = await got();
    expect(first).toMatchObject({ event: "collision", data: { n: 1 } });
    expect(gap).toMatchObject({ event: "gap", data: { lastEventId: Number(first.id), reason: "restart" } });
    expect(second).toMatchObject({ event: "collision", data: { n: 2 } });
    expect(Number(second.id)).toBeGreaterThan(Number(first.id));
  } finally {
    await browser.close();
    await a?.stop();
    await b?.stop();
  }
}, 120_000);
