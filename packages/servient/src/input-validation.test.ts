import { describe, expect, it } from "vitest";
import { ServientError } from "./errors.js";
import { closeSchema } from "@robwot/core";
import { parseBody, validateInput } from "./input-validation.js";

const schema = {
  type: "object",
  properties: {
    joints: { type: "object", properties: { a: { type: "number", minimum: -1, maximum: 1 } }, required: ["a"] },
    speed: { type: "number", exclusiveMinimum: 0, maximum: 1 },
  },
  required: ["joints"],
};

const fails = (value: unknown): ServientError => {
  try {
    validateInput(schema, value, "move");
  } catch (err) {
    return err as ServientError;
  }
  throw new Error("expected a violation");
};

describe("input validation", () => {
  it("closes object schemas without touching enum/const values", () => {
    const closed = closeSchema({ type: "object", properties: { k: { const: { properties: 1 } } } }) as Record<string, unknown>;
    expect(closed.additionalProperties).toBe(false);
    expect((closed.properties as Record<string, { const: unknown }>).k.const).toEqual({ properties: 1 });
  });

  it("accepts a valid input", () => {
    expect(() => validateInput(schema, { joints: { a: 0.5 }, speed: 0.5 }, "move")).not.toThrow();
  });

  it.each([
    ["an unknown property", { joints: { a: 0, b: 1 } }, /unknown property 'b'/],
    ["a missing property", { joints: {} }, /missing required property 'a'/],
    ["a value out of range", { joints: { a: 2 } }, /must be <= 1/],
    ["a wrong type", { joints: { a: "0" } }, /must be number/],
    ["Infinity", { joints: { a: Infinity } }, /finite/],
  ])("refuses %s with a 400 naming the path", (_w, value, message) => {
    const err = fails(value);
    expect(err.status).toBe(400);
    expect(err.message).toMatch(message);
    expect(err.details.action).toBe("move");
  });

  it("parses bodies: JSON, none, not JSON", () => {
    expect(parseBody('{"a":1}', true, "x")).toEqual({ a: 1 });
    expect(parseBody("", false, "stop")).toBeUndefined();
    expect(() => parseBody("", true, "x")).toThrow(/needs a JSON body/);
    expect(() => parseBody("{NaN}", true, "x")).toThrow(/not valid JSON/);
  });
});
