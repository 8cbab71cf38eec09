import { describe, expect, it } from "vitest";
import { createProgress, formatDuration, whileSlow } from "./progress.js";

function sink(tty: boolean) {
  let text = "";
  let t = 0;
  const stream = { write: (s: string) => ((text += s), true), isTTY: tty } as unknown as NodeJS.WriteStream;
  const p = createProgress({ stream, tty, now: () => t });
  return { p, advance: (s: number) => (t += s), text: () => text };
}

describe("progress", () => {
  it("prints plain lines (stage start, quarters with ETA, stage end) when not a TTY", () => {
    const { p, advance, text } = sink(false);
    p.stage("load");
    advance(1);
    for (let done = 0; done <= 100; done += 10) {
      p.update("collide", done, 100);
      advance(0.5);
    }
    p.end();
    const lines = text().trim().split("\n");
    expect(lines[0]).toBe("robwot: load...");
    expect(lines[1]).toBe("robwot: load done in 1.0s");
    expect(lines).toContain("robwot: collide...");
    expect(lines.filter((l) => /collide \d+\/100 \(\d+%, ETA/.test(l))).toHaveLength(3);
    expect(lines.at(-1)).toMatch(/^robwot: collide done in 5\.5s$/);
    expect(text()).not.toContain("\r");
  });

  it("prints one line per step with the caller's ETA when not a TTY, redraws it on a TTY", () => {
    const plain = sink(false);
    plain.p.step("decompose", 1, 3, "link1.stl (5 convex parts, 2.0s)", 12);
    plain.p.step("decompose", 2, 3, "link2.stl (convex, kept, 0.1s)");
    plain.p.end();
    expect(plain.text().trim().split("\n")).toEqual([
      "robwot: decompose...",
      "robwot: decompose 1/3, ETA 12s: link1.stl (5 convex parts, 2.0s)",
      "robwot: decompose 2/3: link2.stl (convex, kept, 0.1s)",
      "robwot: decompose done in 0.0s",
    ]);
    // steps left: an ETA is never printed as 0, and an unknown one is said to be
    const left = sink(false);
    left.p.step("decompose", 2, 3, "small.stl (2 convex parts, 0.3s)", 0.01);
    left.p.step("decompose", 2, 3, "small.stl (2 convex parts, 0.3s)", null);
    left.p.step("decompose", 3, 3, "big.stl (8 convex parts, 54s)", 0);
    expect(left.text().trim().split("\n").slice(1)).toEqual([
      "robwot: decompose 2/3, ETA 0.1s: small.stl (2 convex parts, 0.3s)",
      "robwot: decompose 2/3, ETA unknown: small.stl (2 convex parts, 0.3s)",
      "robwot: decompose 3/3: big.stl (8 convex parts, 54s)",
    ]);
    const tty = sink(true);
    tty.p.step("decompose", 1, 3, "link1.stl (5 convex parts, 2.0s)", 12);
    expect(tty.text()).toMatch(/\r\x1b\[2Kdecompose 1\/3, ETA 12s: link1\.stl \(5 convex parts, 2\.0s\)$/);
  });

  it("redraws one bar with percentage and ETA on a TTY", () => {
    const { p, advance, text } = sink(true);
    p.stage("collide");
    advance(2);
    p.update("collide", 50, 100);
    expect(text()).toMatch(/\r\x1b\[2Kcollide +\[#{14}-{14}\]  50% 50\/100 ETA 2\.0s$/);
    p.end();
    expect(text()).toMatch(/robwot: collide done in 2\.0s\n$/);
  });

  it("formats durations", () => {
    expect(formatDuration(3.21)).toBe("3.2s");
    expect(formatDuration(42.4)).toBe("42s");
    expect(formatDuration(125)).toBe("2m05s");
    // rounded once: never 2m60s nor 60s
    expect(formatDuration(179.6)).toBe("3m00s");
    expect(formatDuration(59.7)).toBe("1m00s");
    expect(formatDuration(9.97)).toBe("10s");
    expect(formatDuration(Number.NaN)).toBe("?");
  });
});

describe("whileSlow", () => {
  const after = <T>(ms: number, value: T): Promise<T> => new Promise((resolve) => setTimeout(() => resolve(value), ms));

  it("speaks once when the work outlasts the delay, and passes its result through", async () => {
    let said = 0;
    await expect(whileSlow(after(80, "model"), 10, () => said++)).resolves.toBe("model");
    expect(said).toBe(1);
  });

  it("stays silent for quick work and after a failure (the timer does not outlive the work)", async () => {
    let said = 0;
    await expect(whileSlow(after(5, 1), 200, () => said++)).resolves.toBe(1);
    await expect(whileSlow(Promise.reject(new Error("E_URDF")), 20, () => said++)).rejects.toThrow("E_URDF");
    await after(60, null);
    expect(said).toBe(0);
  });
});
