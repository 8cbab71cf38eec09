import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import { PushQueue, type PushLimits, type PushTransport } from "./push-queue.js";

const LIMITS: PushLimits = { highWater: 100, maxEvents: 3, stallMs: 1000, closeGraceMs: 500 };

/** A connection whose OS takes bytes only when the test says so (`take`). */
function transport() {
  const t = {
    written: [] as string[],
    inFlight: [] as { size: number; done: () => void }[],
    closed: null as string | null,
    destroyed: false,
    take(n = Infinity): void {
      for (const w of t.inFlight.splice(0, n)) w.done();
    },
  };
  const sink: PushTransport<string> = {
    buffered: () => t.inFlight.reduce((s, w) => s + w.size, 0),
    write: (m, done) => {
      t.written.push(m);
      t.inFlight.push({ size: m.length, done });
    },
    close: (reason) => void (t.closed = reason),
    destroy: () => void (t.destroyed = true),
  };
  return { t, queue: new PushQueue(sink, "test client", LIMITS) };
}

const big = (tag: string): string => tag.padEnd(60, ".");

beforeEach(() => void vi.useFakeTimers());
afterEach(() => void vi.useRealTimers());

describe("PushQueue", () => {
  it("writes at once while the transport is below its high-water mark", () => {
    const { t, queue } = transport();
    queue.push("joints", "j1");
    queue.push(null, "ev1");
    expect(t.written).toEqual(["j1", "ev1"]);
  });

  it("coalesces by key while the client is behind: the latest of each kind, events all kept, in order", () => {
    const { t, queue } = transport();
    queue.push("scene", big("s0"));
    queue.push("scene", big("s1")); // 120 bytes in flight: above the mark, from here on queued
    for (let i = 0; i < 50; i++) queue.push("joints", `j${i}`);
    queue.push(null, "ev1");
    queue.push("scene", big("s2"));
    queue.push("status", "st1");
    queue.push("scene", big("s3"));
    queue.push(null, "ev2");
    expect(t.written).toEqual([big("s0"), big("s1")]);
    t.take();
    t.take();
    t.take();
    expect(t.written.slice(2)).toEqual(["j49", "ev1", "st1", big("s3"), "ev2"]);
  });

  it("disconnects a client with too many undelivered events, with the reason, then destroys the connection", () => {
    const { t, queue } = transport();
    queue.push("scene", big("s0"));
    queue.push("scene", big("s1"));
    for (let i = 0; i < 3; i++) queue.push(null, `ev${i}`);
    expect(t.closed).toBeNull();
    queue.push(null, "ev3");
    expect(t.closed).toMatch(/too slow: more than 3 events undelivered/);
    expect(queue.closed).toBe(true);
    queue.push("joints", "late");
    t.take();
    expect(t.written).toEqual([big("s0"), big("s1")]);
    expect(t.destroyed).toBe(false);
    vi.advanceTimersByTime(500);
    expect(t.destroyed).toBe(true);
  });

  it("disconnects a client whose transport takes nothing for stallMs while messages wait", () => {
    const { t, queue } = transport();
    queue.push("scene", big("s0"));
    queue.push("scene", big("s1"));
    queue.push("joints", "j0");
    vi.advanceTimersByTime(999);
    expect(t.closed).toBeNull();
    vi.advanceTimersByTime(1);
    expect(t.closed).toMatch(/too slow: 120 bytes unread for 1 s/);
  });

  it("keeps a client that is always behind but makes progress, and one that is idle but caught up", () => {
    const { t, queue } = transport();
    vi.advanceTimersByTime(5000); // caught up and idle: no deadline runs
    for (let i = 0; i < 10; i++) {
      queue.push("scene", big(`s${i}`));
      queue.push("joints", `j${i}`);
      vi.advanceTimersByTime(600);
      t.take(1);
    }
    expect(t.closed).toBeNull();
    while (t.inFlight.length > 0) t.take();
    expect(t.written.slice(-2)).toEqual([big("s9"), "j9"]);
    vi.advanceTimersByTime(10_000);
    expect(t.closed).toBeNull();
  });

  it("after dispose, ignores pushes and leaves no timer", () => {
    const { t, queue } = transport();
    queue.push("scene", big("s0"));
    queue.push("scene", big("s1"));
    queue.push("joints", "j0");
    queue.dispose();
    queue.push("joints", "j1");
    vi.advanceTimersByTime(10_000);
    expect(t.closed).toBeNull();
    expect(vi.getTimerCount()).toBe(0);
  });
});
