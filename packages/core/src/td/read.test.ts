import { describe, expect, it } from "vitest";
import { cartesianBounds, jointLimits, linkUrl, liveUrl, slugOf, type ThingDescriptionLike } from "./read.js";

const td: ThingDescriptionLike = {
  title: "arm",
  base: "http://h:1/arm/",
  properties: {
    getJointPosition: {
      type: "object",
      properties: { j1: { type: "number", minimum: -1, maximum: 1, unit: "rad" }, j2: { type: "number", minimum: 0, maximum: 0.04, unit: "m" } },
      forms: [{ href: "http://h:1/arm/properties/getJointPosition" }],
    },
    getCartesianPosition: { type: "object", properties: { x: { type: "number" }, y: { type: "number" }, z: { type: "number" } } },
  },
  actions: {
    moveToCartesianPosition: {
      input: { type: "object", properties: { x: { minimum: -1, maximum: 1 }, y: { minimum: -2, maximum: 2 }, z: { minimum: 0, maximum: 3 } } },
    },
  },
  links: [
    { rel: "workspace", href: "workspace.stl" },
    { rel: "robwot:live", href: "ws://h:1/live" },
  ],
};

describe("td helpers", () => {
  it("reads joint limits in TD order with units", () => {
    expect(jointLimits(td)).toEqual([
      { name: "j1", lower: -1, upper: 1, unit: "rad" },
      { name: "j2", lower: 0, upper: 0.04, unit: "m" },
    ]);
  });

  it("takes Cartesian bounds from the move input (the pose reading has none)", () => {
    expect(cartesianBounds(td)).toEqual({ min: [-1, -2, 0], max: [1, 2, 3] });
    expect(() => cartesianBounds({ title: "none" })).toThrow(/no numeric minimum\/maximum for x/);
  });

  it("resolves links against base and names the missing rel", () => {
    expect(linkUrl(td, "workspace", "http://h:1/arm")).toBe("http://h:1/arm/workspace.stl");
    expect(() => linkUrl(td, "model", "http://h:1/arm")).toThrow(/no link with rel "model" \(links: workspace, robwot:live\)/);
  });

  it("finds the live WebSocket link and the slug", () => {
    expect(liveUrl(td)).toBe("ws://h:1/live");
    expect(liveUrl({ title: "x" })).toBeUndefined();
    expect(slugOf("http://h:1/lbr_iiwa")).toBe("lbr_iiwa");
    expect(() => slugOf("http://h:1/")).toThrow(/no Thing path segment/);
  });
});
