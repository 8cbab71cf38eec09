import { join, resolve } from "node:path";
import { describe, expect, it } from "vitest";
import { parseGenerateArgs } from "./generate-options.js";

const DOBOT = resolve(import.meta.dirname, "../../../../examples/robots/dobot_like.urdf");
const parse = (...args: string[]) => parseGenerateArgs([DOBOT, "--out", join("/tmp", "robwot-couple-test"), ...args]);

describe("--couple and --keep-level", () => {
  it("are repeatable and reach the load as given (the backend reads the rules against the joints)", () => {
    const o = parse("--couple", "joint_4=joint_3-joint_2", "--couple", " j5 = -0.5*j2+j3+0.1 ", "--keep-level", "link_4");
    expect(o.couplings).toEqual(["joint_4=joint_3-joint_2", "j5 = -0.5*j2+j3+0.1"]);
    expect(o.keepLevel).toEqual(["link_4"]);
    expect(parse()).toMatchObject({ couplings: [], keepLevel: [] });
  });

  it("refuse a rule that is not FOLLOWER=EXPR, too many rules and an empty link before anything starts", () => {
    expect(() => parse("--couple", "joint_4")).toThrow(/--couple must be FOLLOWER=EXPR .*got "joint_4"/);
    expect(() => parse("--couple", "a=b=c")).toThrow(/--couple must be FOLLOWER=EXPR/);
    expect(() => parse("--couple", `a=${"b+".repeat(600)}c`)).toThrow(/at most 1024 characters/);
    expect(() => parse(...Array.from({ length: 65 }, (_, i) => ["--couple", `j${i}=j0`]).flat())).toThrow(/at most 64 rules, got 65/);
    expect(() => parse("--keep-level", " ")).toThrow(/--keep-level must name a link/);
  });
});
