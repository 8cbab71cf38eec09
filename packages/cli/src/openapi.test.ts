import { describe, expect, it } from "vitest";
import { toOasSchema } from "./openapi.js";

describe("toOasSchema (TD data schema -> OpenAPI 3.0 Schema Object)", () => {
  it("turns const into a one-value enum and type null into nullable, at every depth", () => {
    expect(toOasSchema({ type: "object", properties: { kind: { type: "string", const: "box" }, none: { type: "null" } } })).toEqual({
      type: "object",
      properties: { kind: { type: "string", enum: ["box"] }, none: { nullable: true } },
    });
  });

  it("turns a numeric exclusive bound into the bound with the boolean flag, unless the inclusive one is tighter", () => {
    expect(toOasSchema({ type: "number", exclusiveMinimum: 0, maximum: 5 })).toEqual({ type: "number", minimum: 0, exclusiveMinimum: true, maximum: 5 });
    expect(toOasSchema({ type: "number", exclusiveMinimum: 0, minimum: 1 })).toEqual({ type: "number", minimum: 1 });
    expect(toOasSchema({ type: "number", exclusiveMinimum: 1, minimum: 0 })).toEqual({ type: "number", minimum: 1, exclusiveMinimum: true });
    expect(toOasSchema({ items: { type: "number", exclusiveMaximum: 2 } })).toEqual({ items: { type: "number", maximum: 2, exclusiveMaximum: true } });
  });

  it("keeps TD terms OpenAPI has no keyword for as x- extensions, and closes what the TD closes", () => {
    const s = toOasSchema({ type: "number", unit: "rad", "@type": "Angle", oneOf: [{ type: "object", properties: {}, additionalProperties: false }] });
    expect(s).toEqual({ type: "number", "x-unit": "rad", "x-@type": "Angle", oneOf: [{ type: "object", properties: {}, additionalProperties: false }] });
  });
});
