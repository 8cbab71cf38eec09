/** The twin's properties: readers by name (`Affordances.properties`), and their changes told to node-wot's
 *  long-poll observers. Every value is served from the twin's in-memory state or the servient's record of
 *  the shared world (`objects`; no backend round trip). */
import { registerReaders, type Affordances } from "./affordance-routes.js";
import { calibrationProperty } from "./calibrate.js";
import type { PhysicalState } from "./follow.js";
import type { SceneRecord } from "./scene-record.js";
import type { SseSource } from "./sse.js";
import type { Twin } from "./twin.js";

/** The twin's change event after which each observable property has a new value. */
const CHANGED_BY = { getJointPosition: "joints", getCartesianPosition: "joints", motionStatus: "status", physicalState: "physical", gripper: "gripper" } as const;
/** The properties that change with the shared world's scene (the record's `scene` event). */
const SCENE_PROPERTIES = ["objects"];
/** The TD's events, each the twin's event of the same name. */
const EVENTS = ["collision", "collisionImminent", "divergence"] as const;

/** What an SSE form streams: an observable property's values (its reader's, after each change) or an event's. */
export function sseSource(twin: Twin, world: SceneRecord, readers: Affordances["properties"], kind: "properties" | "events", name: string): SseSource | null {
  const on = (event: "joints" | "status" | "physical" | "gripper" | (typeof EVENTS)[number], value: (e: unknown) => unknown) => (send: (v: unknown) => void) => {
    const listener = (e: unknown): void => send(value(e));
    twin.on(event, listener as never);
    return () => void twin.off(event, listener as never);
  };
  if (kind === "events") return (EVENTS as readonly string[]).includes(name) ? { subscribe: on(name as (typeof EVENTS)[number], (e) => e) } : null;
  const read = readers.get(name);
  if (read && SCENE_PROPERTIES.includes(name)) {
    return {
      current: read,
      subscribe: (send) => {
        const listener = (): void => send(read());
        world.on("scene", listener);
        return () => void world.off("scene", listener);
      },
    };
  }
  const event = (CHANGED_BY as Record<string, "joints" | "status" | "physical" | "gripper">)[name];
  return read && event ? { current: read, subscribe: on(event, () => read()) } : null;
}

/** `physical`: the follower's state (serve --follow), null when the twin follows no physical robot. The
 *  readers of the properties the TD describes (a folder generated before physicalState existed lacks it). */
export function propertyReaders(described: readonly string[], twin: Twin, world: SceneRecord, physical: () => PhysicalState | null = () => null): Affordances["properties"] {
  const all: [string, () => unknown][] = [
    ["getJointPosition", () => twin.jointsRecord()],
    [
      "getCartesianPosition",
      () => {
        const p = twin.realPose();
        return { ...p.position, orientation: p.orientation };
      },
    ],
    ["motionStatus", () => twin.status],
    ["calibration", () => calibrationProperty(twin.folder.calibration)],
    ["physicalState", () => physical() ?? { following: false, followed: 0 }],
    ["objects", () => world.sceneObjects()],
    ["gripper", () => twin.gripper],
  ];
  return new Map(all.filter(([name]) => described.includes(name)));
}

/** Serves the readers to node-wot's observers and tells them of each change; emits the TD's events. */
export function registerProperties(thing: WoT.ExposedThing, twin: Twin, world: SceneRecord, readers: Affordances["properties"]): void {
  registerReaders(thing, readers);
  // node-wot's emitPropertyChange returns a promise at run time (typed void): never leave it unhandled
  const change = (name: string): void => void Promise.resolve(thing.emitPropertyChange(name) as unknown).catch(() => undefined);
  // node-wot long-poll observers re-read the property on change; joints are throttled to 50 Hz
  let last = 0;
  let timer: NodeJS.Timeout | null = null;
  const emitPose = (): void => {
    last = Date.now();
    timer = null;
    change("getJointPosition");
    change("getCartesianPosition");
  };
  twin.on("joints", () => {
    if (timer) return;
    const wait = 20 - (Date.now() - last);
    if (wait <= 0) emitPose();
    else timer = setTimeout(emitPose, wait);
  });
  twin.on("status", () => change("motionStatus"));
  twin.on("physical", () => change("physicalState"));
  twin.on("gripper", () => change("gripper"));
  if (readers.has("objects")) world.on("scene", () => change("objects"));
  // a twin folder generated before these events existed does not describe them
  const emit = (name: string, e: unknown): void => {
    if (!thing.getThingDescription().events?.[name]) return;
    try {
      thing.emitEvent(name, e as WoT.InteractionInput);
    } catch {
      /* a failing long-poll subscriber must not take the notification path down */
    }
  };
  twin.on("divergence", (e) => emit("divergence", e));
  twin.on("collisionImminent", (e) => emit("collisionImminent", e));
  twin.on("collision", (e) => {
    try {
      thing.emitEvent("collision", e as unknown as WoT.InteractionInput);
    } catch {
      /* a failing long-poll subscriber must not take the notification path down */
    }
  });
}
