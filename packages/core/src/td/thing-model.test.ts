import { describe, expect, it } from "vitest";
import { buildThingDescription, THING_MODEL_FILE, THING_MODEL_TYPE, WOT_PROFILES } from "./build.js";
import { buildThingModel } from "./thing-model.js";
import { validateThingModel } from "./validate.js";

describe("the robot-arm Thing Model", () => {
  const tm = buildThingModel() as Record<string, any>;

  it("is a TD 1.1 Thing Model valid against the official TM schema", async () => {
    expect(tm["@type"]).toBe("tm:ThingModel");
    const r = await validateThingModel(tm);
    expect(r.errors).toEqual([]);
    expect(r.valid).toBe(true);
  });

  it("has every affordance of a twin's TD, with placeholders for the robot and its bounds, and no forms", () => {
    const td = buildThingDescription({
      model: { name: "r", eeLink: "l", controllable: ["a"], joints: [{ name: "a", type: "revolute", lower: -1, upper: 1, velocity: 1, effort: 1 }] },
      summary: null,
    });
    for (const kind of ["properties", "actions", "events"] as const) expect(Object.keys(tm[kind]).sort()).toEqual(Object.keys(td[kind]).sort());
    expect(tm.title).toBe("{{ROBOT_NAME}}");
    expect(tm.actions.moveToCartesianPosition.input.properties.x).toMatchObject({ minimum: "{{X_MIN}}", maximum: "{{X_MAX}}" });
    expect(tm.properties.getJointPosition.properties).toBeUndefined();
    expect(JSON.stringify(tm)).not.toContain('"forms"');
    expect(td.links).toContainEqual({ rel: "type", href: THING_MODEL_FILE, type: THING_MODEL_TYPE });
    // its instances conform to the WoT Profiles: the model says so, and keeps synchronous on every action
    expect(tm.profile).toEqual([...WOT_PROFILES]);
    for (const [name, a] of Object.entries(tm.actions as Record<string, { synchronous?: unknown }>)) expect(a.synchronous, name).toBe(true);
  });
});
