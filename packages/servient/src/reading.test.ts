import { describe, expect, it } from "vitest";
import { clip, describe as describeValue, LIMIT_TOLERANCE, MAX_ERROR_TEXT, parseJointRecord, quote, withinLimits, type JointRange } from "./reading.js";

const ranges: JointRange[] = [
  { name: "r", type: "revolute", lower: -1, upper: 1 },
  { name: "p", type: "prismatic", lower: 0, upper: 0.5 },
  { name: "c", type: "continuous", lower: -Math.PI, upper: Math.PI },
];

describe("withinLimits", () => {
  it.each([
    ["inside", [0.5, 0.2, 1], [0.5, 0.2, 1], {}],
    ["a revolute joint just past its upper limit: clamped, noted", [1 + LIMIT_TOLERANCE.rad / 2, 0.2, 0], [1, 0.2, 0], { r: 1 + LIMIT_TOLERANCE.rad / 2 }],
    ["a prismatic joint just below its lower limit: clamped, noted", [0, -LIMIT_TOLERANCE.m / 2, 0], [0, 0, 0], { p: -LIMIT_TOLERANCE.m / 2 }],
    ["a continuous joint a turn and a half around: the same angle within [-pi, pi]", [0, 0, 3 * Math.PI + 0.5], [0, 0, Math.PI + 0.5 - 2 * Math.PI], {}],
  ])("%s", (_what, q, expected, clamped) => {
    const r = withinLimits(q, ranges);
    r.q.forEach((v, i) => expect(v).toBeCloseTo(expected[i]!, 12));
    expect(r.clamped).toEqual(clamped);
  });

  it.each([
    ["a revolute joint past the tolerance", [1 + 2 * LIMIT_TOLERANCE.rad, 0, 0], /^getJointPosition\.r: .* rad is beyond its limits \[-1, 1\]/],
    ["a prismatic joint past the tolerance", [0, 0.5 + 2 * LIMIT_TOLERANCE.m, 0], /^getJointPosition\.p: .* m is beyond its limits \[0, 0\.5\]/],
  ])("refuses %s, naming the joint", (_what, q, error) => {
    expect(() => withinLimits(q, ranges)).toThrow(error);
  });
});

describe("bounded texts", () => {
  it("clip keeps at most MAX_ERROR_TEXT UTF-8 bytes, also of multi-byte characters", () => {
    for (const ch of ["a", "é", "€", "😀"]) {
      const out = clip(ch.repeat(10_000));
      expect(Buffer.byteLength(out)).toBeLessThanOrEqual(MAX_ERROR_TEXT);
      expect(out.endsWith("...")).toBe(true);
      expect(out).not.toMatch(/\uFFFD/);
    }
    expect(clip("short")).toBe("short");
  });

  it("quote never cuts a surrogate pair and says how long the name was", () => {
    const name = `${"x".repeat(39)}😀${"y".repeat(100)}`;
    const q = quote(name);
    expect(q).toBe(`${JSON.stringify("x".repeat(39))}... (${name.length} characters)`);
  });

  it("describe names a value's kind and size, never its content", () => {
    expect(describeValue(Array(5).fill("secret"))).toBe("an array of 5 items");
    expect(describeValue({ secret: 1 })).toBe("an object of 1 key(s)");
    expect(describeValue(undefined)).toBe("nothing");
  });

  it("a reading's unknown names are listed up to three, counted beyond", () => {
    const value = { a: 0, ...Object.fromEntries(Array.from({ length: 10 }, (_, i) => [`u${i}`, 0])) };
    expect(() => parseJointRecord(value, ["a"])).toThrow(/^getJointPosition: 10 unknown joint\(s\) "u0", "u1", "u2" and 7 more; the twin's joints are "a"$/);
  });
});
