import { describe, expect, it } from "vitest";
import { spreadTargets } from "./targets.js";
import { parseArgs, numberOption, UsageError } from "./args.js";
import { schemaViolations } from "./connect.js";

describe("spreadTargets", () => {
  const limits = [
    { name: "a", lower: -2.9, upper: 2.9, unit: "rad" },
    { name: "b", lower: -3.14, upper: 0, unit: "rad" },
    { name: "f", lower: 0, upper: 0.04, unit: "m" },
  ];
  it.each([0.1, 0.35, 0.9])("keeps every target strictly inside the limits (fraction %d)", (f) => {
    const targets = spreadTargets(limits, f, 16);
    expect(new Set(targets.map((t) => JSON.stringify(t))).size).toBe(16);
    for (const t of targets) for (const l of limits) {
      expect(t[l.name]).toBeGreaterThan(l.lower);
      expect(t[l.name]).toBeLessThan(l.upper);
    }
  });
});

describe("parseArgs", () => {
  const known = { speed: "value", json: "flag" } as const;
  it("splits positionals, values and flags", () => {
    const a = parseArgs(["http://x/t", "--speed", "0.5", "--json"], known);
    expect(a.positional).toEqual(["http://x/t"]);
    expect(numberOption(a, "speed", 1, 0.01, 1)).toBe(0.5);
    expect(a.options.get("json")).toBe(true);
    expect(numberOption(parseArgs(["--speed=0.25"], known), "speed", 1, 0.01, 1)).toBe(0.25);
  });
  it.each([
    [["--sped", "1"], /unknown option --sped \(valid: --speed, --json\)/],
    [["--speed"], /--speed needs a value/],
  ])("refuses %j", (argv, message) => {
    expect(() => parseArgs(argv, known)).toThrow(message);
    expect(() => parseArgs(argv, known)).toThrow(UsageError);
  });
  it("refuses out-of-range numbers", () => {
    expect(() => numberOption(parseArgs(["--speed", "NaN"], known), "speed", 1, 0.01, 1)).toThrow(/got NaN/);
  });
});

describe("schemaViolations", () => {
  it("names each number outside its minimum/maximum", () => {
    const schema = { properties: { x: { minimum: 0, maximum: 1 }, o: { properties: { w: { maximum: 1 } } } } };
    expect(schemaViolations({ x: 1.5, o: { w: 2 } }, schema)).toEqual(["x=1.5 > maximum 1", "o.w=2 > maximum 1"]);
    expect(schemaViolations({ x: 0.5, o: { w: 1 } }, schema)).toEqual([]);
  });
});
