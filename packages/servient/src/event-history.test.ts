import { describe, expect, it } from "vitest";
import { EventHistory, resumePoint, Sequence } from "./event-history.js";

const T0 = Date.parse("2026-11-26T12:00:00Z");

describe("EventHistory", () => {
  it("numbers messages one after the other from the creation time in ms x 1000, above every number of an earlier run", () => {
    const earlier = new Sequence(T0);
    for (let i = 0; i < 999; i++) earlier.take();
    const later = new Sequence(T0 + 1);
    expect(later.first).toBe((T0 + 1) * 1000 + 1);
    expect(later.take()).toBeGreaterThan(earlier.take());
  });

  it("replays what came after a number; nothing and no gap for the newest or a number not given yet", () => {
    const h = new EventHistory<string>(new Sequence(T0), 4);
    const seqs = ["a", "b", "c"].map((x) => {
      let n = 0;
      h.record((seq) => ((n = seq), x));
      return n;
    });
    expect(h.since(seqs[0]!)).toEqual({ replay: ["b", "c"], gap: null });
    expect(h.since(seqs[2]!)).toEqual({ replay: [], gap: null });
    expect(h.since(seqs[2]! + 100)).toEqual({ replay: [], gap: null });
    // every number of this run is known: resuming from just before the first misses nothing
    expect(h.since(h.numbers.first - 1)).toEqual({ replay: ["a", "b", "c"], gap: null });
  });

  it("a number older than the kept ones: the gap (overflow), then all that is kept; of an earlier run: restart", () => {
    const numbers = new Sequence(T0);
    const h = new EventHistory<number>(numbers, 3);
    // a number taken by another stream sharing the sequence, then six kept ones of which three stay
    numbers.take();
    const seqs: number[] = [];
    for (let i = 0; i < 6; i++) h.record((seq) => (seqs.push(seq), i));
    expect(h.since(seqs[1]!)).toEqual({ replay: [3, 4, 5], gap: { lastSeen: seqs[1], firstKept: seqs[3], reason: "overflow" } });
    expect(h.since(seqs[2]!)).toEqual({ replay: [3, 4, 5], gap: null });
    expect(h.since(7)).toEqual({ replay: [3, 4, 5], gap: { lastSeen: 7, firstKept: seqs[3], reason: "restart" } });
  });

  it("reads a resume point: decimal digits only", () => {
    expect(resumePoint(" 1764158400000001 ")).toBe(1764158400000001);
    expect(resumePoint(["12", "13"])).toBe(12);
    for (const bad of [undefined, null, "", "-1", "1e3", "12abc", "99999999999999999"]) expect(resumePoint(bad)).toBeNull();
  });
});
