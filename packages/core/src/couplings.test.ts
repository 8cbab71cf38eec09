import { describe, expect, it } from "vitest";
import { tdCouplings, withFollowers } from "./couplings.js";
import { buildThingDescription, thingId } from "./td/build.js";
import { validateThingDescription } from "./td/validate.js";
import { kukaLikeModel, summaryFixture } from "./test-support/models.js";

const level = { follower: "a7", terms: [{ joint: "a2", factor: -1 }, { joint: "a3", factor: -1 }], offset: 0.1, expression: "a7=-a2-a3+0.1", source: "keep-level" as const };

describe("couplings", () => {
  it("adds each follower's value from the leaders (a missing leader counts as 0)", () => {
    expect(withFollowers({ a2: 0.5, a3: 0.25 }, [level])).toEqual({ a2: 0.5, a3: 0.25, a7: -0.65 });
    expect(withFollowers({ a2: 0.5 }, [level])).toEqual({ a2: 0.5, a7: -0.4 });
    const joints = { a2: 1 };
    expect(withFollowers(joints, [])).toBe(joints);
  });

  it("are stated in the TD (robwot:couplings), change the Thing id, and read back; mimic tags alone change nothing", async () => {
    const base = kukaLikeModel();
    const mimic = { ...level, follower: "f", terms: [{ joint: "a1", factor: 1 }], offset: 0, expression: "f=a1", source: "mimic" as const };
    const model = { ...base, couplings: [mimic, level] };
    const td = buildThingDescription({ model, summary: summaryFixture(), sceneId: "s" }) as unknown as Record<string, unknown>;
    expect(td["robwot:couplings"]).toEqual([mimic, level]);
    expect((await validateThingDescription(td)).errors).toEqual([]);
    expect(tdCouplings(td)).toEqual([mimic, level]);
    expect(thingId(model, "arm", "s")).not.toBe(thingId(base, "arm", "s"));
    expect(thingId({ ...base, couplings: [mimic] }, "arm", "s")).toBe(thingId(base, "arm", "s"));
    const plain = buildThingDescription({ model: base, summary: summaryFixture() }) as unknown as Record<string, unknown>;
    expect("robwot:couplings" in plain).toBe(false);
  });

  it("leaves out a malformed TD entry rather than drawing it wrong", () => {
    const td = { "robwot:couplings": [level, { follower: "x" }, { ...level, terms: [{ joint: 3, factor: 1 }] }, null] };
    expect(tdCouplings(td)).toEqual([level]);
    expect(tdCouplings({})).toEqual([]);
  });
});
