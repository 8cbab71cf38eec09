/**
 * Every boundary number lives in the backend contract (sim-backend/src/robwot_sim/schemas/protocol.openrpc.json):
 * each surface reads its limit from there (generated `VALUE_SCHEMAS` in TS, `robwot_sim.limits` in Python),
 * and no source file keeps a copy of a contract number beside the name of what it bounds.
 */
import { readFileSync, readdirSync } from "node:fs";
import { dirname, join, relative } from "node:path";
import { fileURLToPath } from "node:url";
import { buildThingDescription, speedRange, type ThingDescriptionLike } from "@robwot/core";
import { TRANSPORT, VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { describe, expect, it } from "vitest";
import { parseRealtime } from "../packages/cli/src/args.js";
import { kukaLikeModel, summaryFixture } from "../packages/core/src/test-support/models.js";
import { parseGenerateArgs } from "../packages/cli/src/commands/generate-options.js";

const ROOT = join(dirname(fileURLToPath(import.meta.url)), "..");
const { Clearance, Dt, Name, Position, QuatXyzw, RealtimeFactor, ReachVoxel, Samples, Speed } = VALUE_SCHEMAS;

/** The ways a number is written in TS or Python: 0.0005, 5e-4, 10000, 10_000, 1e4. */
function spellings(v: number): string[] {
  const out = new Set([String(v), v.toExponential().replace("e+", "e").replace(/\.0+e/, "e")]);
  if (Number.isInteger(v) && v >= 1000) out.add(v.toLocaleString("en-US").replaceAll(",", "_"));
  return [...out];
}

const escape = (s: string): string => s.replace(/[.*+?^${}()|[\]\\]/g, "\\$&");
const literal = (values: number[]): RegExp =>
  new RegExp(`(?<![\\w.])(${values.flatMap(spellings).map(escape).join("|")})(?![\\w.])`);

/** A concept the contract bounds: the words that name it on a line, and its numbers. */
const RULES: { concept: string; words: RegExp; numbers: RegExp }[] = [
  { concept: "speed", words: /\bspeed/i, numbers: literal([Speed.minimum]) },
  { concept: "clearance", words: /clearance/i, numbers: literal([Clearance.minimum, Clearance.maximum, Clearance.default]) },
  { concept: "dt", words: /\bdt\b/, numbers: literal([Dt.minimum, Dt.maximum]) },
  { concept: "realtime", words: /realtime/i, numbers: literal([RealtimeFactor.minimum, RealtimeFactor.maximum]) },
  { concept: "reach voxel", words: /reach.?voxel|M(IN|AX)_VOXEL/i, numbers: literal([ReachVoxel.minimum, ReachVoxel.maximum]) },
  { concept: "coordinate", words: /coordinate|position|rpy/i, numbers: literal([Position.items.maximum]) },
  { concept: "name length", words: /\bname\b.*(length|chars|characters|len\()|maxLength/i, numbers: literal([Name.maxLength]) },
  { concept: "quaternion norm", words: /\bnorm\b|hypot/i, numbers: literal([QuatXyzw["x-minNorm"]]) },
  { concept: "samples", words: /samples/i, numbers: literal([Samples.maximum]) },
  { concept: "transport", words: /heartbeat|dead.?after|(request|start|stop|connect).?timeout|restoreMs/i, numbers: literal(Object.values(TRANSPORT)) },
];

function sources(dir: string, ext: string): string[] {
  return readdirSync(join(ROOT, dir), { recursive: true, encoding: "utf8" })
    .filter((f) => f.endsWith(ext) && !f.endsWith(".test.ts") && !f.includes("node_modules") && !f.includes("dist/"))
    .map((f) => join(ROOT, dir, f));
}

describe("the contract owns every boundary number", () => {
  it("no source keeps a copy of a contract range or default beside the name of what it bounds", () => {
    const files = [
      ...["core", "sim-client", "servient", "cli", "viewer", "consumers"].flatMap((p) => sources(`packages/${p}/src`, ".ts")),
      ...sources("sim-backend/src/robwot_sim", ".py"),
      // the benches and scripts too: a bench that copies a range measures something else once it moves
      ...sources("sim-backend/src/robwot_bench", ".py"),
      ...sources("scripts", ".mjs"),
    ].filter((f) => !f.endsWith("backend-contract.ts"));
    expect(files.length).toBeGreaterThan(100);
    const copies: string[] = [];
    for (const file of files) {
      readFileSync(file, "utf8").split("\n").forEach((line, i) => {
        for (const r of RULES) {
          if (r.words.test(line) && r.numbers.test(line)) copies.push(`${relative(ROOT, file)}:${i + 1} [${r.concept}] ${line.trim()}`);
        }
      });
    }
    expect(copies).toEqual([]);
  });

  it("the scan finds a copy when there is one", () => {
    const line = "  if (s < 0.001 || s > 1) throw badInput(`speed must be in [0.001, 1]`);";
    const r = RULES.find((x) => x.concept === "speed")!;
    expect(r.words.test(line) && r.numbers.test(line)).toBe(true);
    const clearance = RULES.find((x) => x.concept === "clearance")!;
    expect(clearance.numbers.test("const MIN_CLEARANCE = 5e-4; // clearance")).toBe(true);
    expect(clearance.numbers.test("clearance 0.0025")).toBe(false);
  });
});

describe("each surface reads its limit from the contract", () => {
  const td = buildThingDescription({ model: kukaLikeModel(), summary: summaryFixture() }) as unknown as ThingDescriptionLike;

  it("the TD: speed range, obstacle name length, positions", () => {
    expect(speedRange(td)).toEqual({ minimum: Speed.minimum, maximum: Speed.maximum });
    const add = (td.actions?.["addObstacle"]?.input ?? {}) as { properties?: Record<string, { maxLength?: number; items?: { maximum?: number } }> };
    expect(add.properties?.["name"]?.maxLength).toBe(Name.maxLength);
    expect(add.properties?.["position"]?.items?.maximum).toBe(Position.items.maximum);
  });

  it("the CLI: clearance, samples, reach voxel and realtime ranges and defaults", () => {
    const parse = (...args: string[]) => parseGenerateArgs(["two_joint", ...args]);
    expect(parse().clearance).toBe(Clearance.default);
    expect(parse().samples).toBe(Samples.default);
    expect(() => parse("--clearance", String(Clearance.minimum / 2))).toThrow(`between ${Clearance.minimum} and ${Clearance.maximum}`);
    expect(parse("--clearance", String(Clearance.maximum)).clearance).toBe(Clearance.maximum);
    expect(() => parse("--samples", String(Samples.maximum + 1))).toThrow(`between ${Samples.minimum} and ${Samples.maximum}`);
    expect(() => parse("--reach-voxel", String(ReachVoxel.maximum * 2))).toThrow(`between ${ReachVoxel.minimum} and ${ReachVoxel.maximum}`);
    expect(() => parseRealtime(String(RealtimeFactor.minimum / 2))).toThrow(`between ${RealtimeFactor.minimum} and ${RealtimeFactor.maximum}`);
    expect(parseRealtime(String(RealtimeFactor.minimum))).toBe(RealtimeFactor.minimum);
  });
});
