import { describe, expect, it } from "vitest";
import { buildThingDescription } from "./build.js";
import { validateThingDescription, validateThingModel } from "./validate.js";

const td = buildThingDescription({
  model: { name: "r", eeLink: "l", controllable: ["a"], joints: [{ name: "a", type: "revolute", lower: -1, upper: 1, velocity: 1, effort: 1 }] },
  summary: null,
});

describe("the TD validator's thread", () => {
  it("validates off the caller's event loop, which keeps turning meanwhile", async () => {
    let turns = 0;
    let validating = true;
    const turn = (): void => {
      turns += 1;
      if (validating) setImmediate(turn);
    };
    setImmediate(turn);
    const r = await validateThingDescription(td);
    validating = false;
    expect(r.errors).toEqual([]);
    // in the caller's thread the validator runs through in one turn (its work is synchronous)
    expect(turns).toBeGreaterThan(10);
  });

  it("answers concurrent validations each with its own verdict", async () => {
    const bad = structuredClone(td) as Record<string, any>;
    bad.properties.broken = { type: "number" }; // no forms
    const [good, wrong, notJson] = await Promise.all([validateThingDescription(td), validateThingDescription(bad), validateThingDescription("{")]);
    expect(good.valid).toBe(true);
    expect(wrong.valid).toBe(false);
    expect(wrong.errors.join()).toContain("forms");
    expect(notJson.errors).toContain("not valid JSON");
  });
});

describe("the TD validator's compiled schemas", () => {
  it("give each validation its own verdict, whatever was validated before in the thread", async () => {
    const bad = structuredClone(td) as Record<string, any>;
    bad.properties.broken = { type: "number" }; // no forms
    const first = await validateThingDescription(bad);
    expect(first.valid).toBe(false);
    expect((await validateThingDescription(td)).valid).toBe(true);
    const tm = await validateThingModel({ "@context": "https://www.w3.org/2022/wot/td/v1.1", "@type": "tm:ThingModel", title: "t", properties: { p: { type: "nonsense" } } });
    expect(tm.valid).toBe(false);
    expect(await validateThingDescription(bad)).toEqual(first);
    expect((await validateThingDescription(td)).errors).toEqual([]);
  });
});
