/** The cell devices' TDs: the lab's affordance names, SI units, the contract's speed range, absolute forms
 *  (long poll first, then SSE), valid TD 1.1 by the official validator's schema. */
import { describe, expect, it } from "vitest";
import { VALUE_SCHEMAS } from "../backend-contract.js";
import { conveyorThingDescription, sensorThingDescription } from "./cell-things.js";
import { validateThingDescription } from "./validate.js";

const belt = { name: "belt", size: [0.8, 0.15, 0.2], position: [0.5, -0.5, 0.1], orientation: [0, 0, 0.7071, 0.7071], speed: 0.05, endStop: true, state: "stopped" as const };
const at = { baseUrl: "http://127.0.0.1:8080/", path: "belt" };

describe("cell Things", () => {
  it("a conveyor: start/stop actions, speed (m/s, the contract's range, writable) and state", async () => {
    const td = conveyorThingDescription(belt, at);
    expect(td.base).toBe("http://127.0.0.1:8080/belt/");
    expect(Object.keys(td.actions)).toEqual(["startBeltForward", "startBeltBackward", "stopBelt"]);
    expect(td.actions["startBeltForward"]!.forms[0]).toMatchObject({ href: "http://127.0.0.1:8080/belt/actions/startBeltForward", op: ["invokeaction"], "htv:methodName": "POST" });
    expect(td.properties["speed"]).toMatchObject({ unit: "m/s", readOnly: false, exclusiveMinimum: VALUE_SCHEMAS.BeltSpeed.exclusiveMinimum, maximum: VALUE_SCHEMAS.BeltSpeed.maximum });
    expect(td.properties["speed"]!.forms.map((f) => f.op)).toEqual([["readproperty"], ["writeproperty"], ["observeproperty", "unobserveproperty"], ["observeproperty", "unobserveproperty"]]);
    expect(td.properties["state"]!.enum).toEqual(["stopped", "forward", "backward"]);
    expect((await validateThingDescription(td)).errors).toEqual([]);
  });

  it("a presence sensor: objectPresence (observable), detectedObject {object, time (s)} over long poll and SSE", async () => {
    const td = sensorThingDescription({ name: "beam", kind: "presence", size: [0.2, 0.004, 0.01], position: [0.5, -0.15, 0.215], orientation: [0, 0, 0, 1] }, { ...at, path: "beam" });
    expect(td.properties["objectPresence"]).toMatchObject({ type: "boolean", observable: true, readOnly: true });
    expect(td.properties["color"]).toBeUndefined();
    expect(td.events["detectedObject"]!.forms.map((f) => f.subprotocol)).toEqual(["longpoll", "sse"]);
    expect(td.events["detectedObject"]!.data!.properties!["time"]!.unit).toBe("s");
    expect((await validateThingDescription(td)).errors).toEqual([]);
  });

  it("a colour sensor: color {r, g, b} integers 0-255 or null", async () => {
    const td = sensorThingDescription({ name: "eye", kind: "color", size: [0.05, 0.05, 0.05], position: [0.5, -0.3, 0.225], orientation: [0, 0, 0, 1] }, { ...at, path: "eye" });
    const [rgb, none] = td.properties["color"]!.oneOf!;
    expect(rgb!.properties!["r"]).toEqual({ type: "integer", minimum: 0, maximum: 255 });
    expect(none).toEqual({ type: "null" });
    expect((await validateThingDescription(td)).errors).toEqual([]);
  });

  it("gives each device a stable id of its own", () => {
    expect(conveyorThingDescription(belt, at).id).toBe(conveyorThingDescription({ ...belt, state: "forward" }, at).id);
    expect(conveyorThingDescription(belt, at).id).not.toBe(conveyorThingDescription({ ...belt, position: [0, 0, 0.1] }, at).id);
  });
});
