/**
 * Thing Descriptions (TD 1.1) of the cell's devices around the robots: each conveyor belt and each sensor
 * of the shared world is a Thing of its own, served by the same servient as the twins (README "Conveyors
 * and sensors as Things"). The affordance names are the lab's (the paper's conveyor belts, infrared and
 * colour sensors): a conveyor `startBeltForward` / `startBeltBackward` / `stopBelt`, `speed` and `state`; a
 * presence sensor `objectPresence` and the `detectedObject` / `objectLeft` events; a colour sensor also
 * `color`. Units are SI (`m/s`, `s`); forms are absolute under `base` = `<baseUrl><path>/`, in the router's
 * layout (`properties/<name>`, `properties/<name>/observable` (long poll) and `/sse`, `actions/<name>`,
 * `events/<name>` (long poll) and `events/<name>/sse`).
 */
import { VALUE_SCHEMAS } from "../backend-contract.js";
import type { Conveyor, Sensor } from "../backend-contract.js";
import { TD_CONTEXT_V10, TD_CONTEXT_V11, ROBWOT_NS, WOT_PROFILES, withAbsoluteForms } from "./build.js";
import { canonicalJson, fnv1a64 } from "./hash.js";
import { PROBLEM_JSON, PROBLEM_SCHEMA } from "./problem.js";
import type { ActionAffordance, DataSchema, EventAffordance, Form, PropertyAffordance, ThingDescription } from "./types.js";

const JSON_TYPE = "application/json";
/** Error answers of a device's action: 400 bad input, 404 unknown device, 503 backend down, 504 timeout. */
const ACTION_ERRORS = [400, 404, 415, 503, 504].map((status) => ({ success: false, contentType: PROBLEM_JSON, schema: "error", "htv:statusCodeValue": status }));
const READ_ERRORS = [{ success: false, contentType: PROBLEM_JSON, schema: "error" }];

/** Where a device is served and what it is called. */
export interface CellThingOptions {
  /** absolute http(s) URL of the servient, e.g. `http://127.0.0.1:8080` */
  baseUrl: string;
  /** the device's URL path segment */
  path: string;
}

/** The value a conveyor's `speed` takes (m/s): the contract's belt speed range. */
export const BELT_SPEED_SCHEMA: DataSchema = speedSchema();

export const CONVEYOR_ACTIONS = { startBeltForward: "forward", startBeltBackward: "backward", stopBelt: "stopped" } as const;

/** A conveyor's state as its actions answer it and its properties read it. */
export const CONVEYOR_STATE_SCHEMA: DataSchema = {
  type: "object",
  properties: {
    state: { type: "string", enum: ["stopped", "forward", "backward"], description: "stopped, running forward (along the belt's local +x) or backward" },
    speed: { ...speedSchema(), description: "belt surface speed (m/s)" },
    changed: { type: "boolean", description: "false: the belt already was in this state (starting a running belt again changes nothing)" },
  },
  required: ["state", "speed", "changed"],
};

function speedSchema(): DataSchema {
  const s = VALUE_SCHEMAS.BeltSpeed;
  return { type: "number", exclusiveMinimum: s.exclusiveMinimum, maximum: s.maximum, unit: "m/s" };
}

const OBJECT_EVENT: DataSchema = {
  type: "object",
  properties: {
    object: { type: "string", description: "the object's name (the twins' `objects` property names it)" },
    time: { type: "number", minimum: 0, unit: "s", description: "the cell's simulated time it happened at" },
  },
  required: ["object", "time"],
};

const COLOR_SCHEMA: DataSchema = {
  description: "RGB of the object in view nearest the sensor's centre (integers 0-255; grey 128,128,128 for an object without a colour), null when nothing is in view",
  oneOf: [
    {
      type: "object",
      properties: Object.fromEntries(["r", "g", "b"].map((c) => [c, { type: "integer", minimum: 0, maximum: 255 }])) as Record<string, DataSchema>,
      required: ["r", "g", "b"],
    },
    { type: "null" },
  ],
};

function property(name: string, schema: DataSchema, observable: boolean, writable = false): PropertyAffordance {
  const forms: Form[] = [{ href: `properties/${name}`, contentType: JSON_TYPE, op: ["readproperty"], "htv:methodName": "GET", additionalResponses: READ_ERRORS }];
  if (writable) forms.push({ href: `properties/${name}`, contentType: JSON_TYPE, op: ["writeproperty"], "htv:methodName": "PUT", additionalResponses: ACTION_ERRORS });
  if (observable) {
    // long poll first: node-wot 0.9.2 consumers take the first form and hear no named SSE message
    forms.push({ href: `properties/${name}/observable`, contentType: JSON_TYPE, op: ["observeproperty", "unobserveproperty"], subprotocol: "longpoll" });
    forms.push({ href: `properties/${name}/sse`, contentType: JSON_TYPE, op: ["observeproperty", "unobserveproperty"], subprotocol: "sse" });
  }
  return { ...schema, readOnly: !writable, observable, forms };
}

function event(name: string, description: string): EventAffordance {
  return {
    description,
    data: OBJECT_EVENT,
    forms: [
      { href: `events/${name}`, contentType: JSON_TYPE, op: ["subscribeevent", "unsubscribeevent"], subprotocol: "longpoll" },
      { href: `events/${name}/sse`, contentType: JSON_TYPE, op: ["subscribeevent", "unsubscribeevent"], subprotocol: "sse" },
    ],
  };
}

function frame(kind: string, name: string, o: CellThingOptions, spec: unknown, description: string): ThingDescription {
  const base = `${o.baseUrl.replace(/\/+$/, "")}/${encodeURIComponent(o.path)}/`;
  return {
    "@context": [TD_CONTEXT_V10, TD_CONTEXT_V11, { "@language": "en", robwot: ROBWOT_NS }],
    "@type": ["Thing", `robwot:${kind}`],
    id: `urn:robwot:cell:${o.path}:${fnv1a64(canonicalJson({ kind, name, spec }))}`,
    profile: [...WOT_PROFILES],
    title: name,
    description,
    base,
    securityDefinitions: { nosec_sc: { scheme: "nosec" } },
    security: "nosec_sc",
    schemaDefinitions: { error: PROBLEM_SCHEMA },
    properties: {},
    actions: {},
    events: {},
    links: [],
    forms: [{ href: "properties", contentType: JSON_TYPE, op: ["readallproperties"], "htv:methodName": "GET" }],
    "robwot:name": name,
  };
}

/** A box as the TD states it: world frame, m, quaternion [x, y, z, w]. */
function box(b: { size: number[]; position: number[]; orientation: number[] }): Record<string, unknown> {
  return { size: b.size, position: b.position, orientation: b.orientation, unit: "m", frame: "world" };
}

/** The TD of a conveyor belt. */
export function conveyorThingDescription(c: Conveyor, o: CellThingOptions): ThingDescription {
  const spec = { size: c.size, position: c.position, orientation: c.orientation, endStop: c.endStop };
  const td = frame("Conveyor", c.name, o, spec, `Conveyor belt '${c.name}' of the simulated cell (${c.size[0]} m long; forward = the belt's local +x${c.endStop ? "; objects stop at its end" : "; objects fall off its end"}). It carries the objects resting on it while it runs.`);
  const answer = (state: string, text: string): ActionAffordance => ({
    title: text,
    description: `${text}; answers the belt's state (changed: false when it already was ${state})`,
    output: CONVEYOR_STATE_SCHEMA,
    safe: false,
    idempotent: true,
    synchronous: true,
    forms: [],
  });
  td.actions = {
    startBeltForward: answer("forward", "Start the belt forward"),
    startBeltBackward: answer("backward", "Start the belt backward"),
    stopBelt: answer("stopped", "Stop the belt"),
  };
  for (const [name, a] of Object.entries(td.actions)) {
    a.forms = [{ href: `actions/${name}`, contentType: JSON_TYPE, op: ["invokeaction"], "htv:methodName": "POST", additionalResponses: ACTION_ERRORS }];
  }
  td.properties = {
    speed: property("speed", { ...speedSchema(), title: "Speed", description: "belt surface speed while it runs (m/s); writable (PUT, 204): the belt keeps its state" }, true, true),
    state: property("state", { type: "string", enum: ["stopped", "forward", "backward"], title: "State", description: "stopped, running forward or backward" }, true),
  };
  td["robwot:belt"] = box(c);
  return withAbsoluteForms(td);
}

/** The TD of a presence (infrared) or colour sensor. */
export function sensorThingDescription(s: Pick<Sensor, "name" | "kind" | "size" | "position" | "orientation">, o: CellThingOptions): ThingDescription {
  const color = s.kind === "color";
  const spec = { kind: s.kind, size: s.size, position: s.position, orientation: s.orientation };
  const what = color ? "Colour sensor" : "Infrared presence sensor";
  const td = frame(color ? "ColorSensor" : "PresenceSensor", s.name, o, spec, `${what} '${s.name}' of the simulated cell: an object is in view when its bounding box overlaps the sensor's field of view (a box).`);
  td.properties = {
    objectPresence: property("objectPresence", { type: "boolean", title: "Object present", description: "true while an object is in the sensor's field of view" }, true),
    object: property("object", { oneOf: [{ type: "string" }, { type: "null" }], title: "Object in view", description: "the name of the object in view nearest the sensor's centre, null when none" }, true),
    ...(color ? { color: property("color", { ...COLOR_SCHEMA, title: "Detected colour" }, true) } : {}),
  };
  td.events = {
    detectedObject: event("detectedObject", "An object came into view (the rising edge of objectPresence)"),
    objectLeft: event("objectLeft", "The object in view left it and nothing else is in view (the falling edge of objectPresence)"),
  };
  td["robwot:fieldOfView"] = box(s);
  return withAbsoluteForms(td);
}
