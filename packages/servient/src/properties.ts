/** Property read handlers: served from the twin's in-memory state (no backend round trip). */
import { calibrationProperty } from "./calibrate.js";
import type { PhysicalState } from "./follow.js";
import { recordErrors } from "./request-context.js";
import type { Twin } from "./twin.js";

/** `physical`: the follower's state (serve --follow), null when the twin follows no physical robot. */
export function registerProperties(thing: WoT.ExposedThing, twin: Twin, physical: () => PhysicalState | null = () => null): void {
  const read = (fn: () => unknown): WoT.PropertyReadHandler => recordErrors(async () => fn() as WoT.InteractionInput);
  // a twin folder generated before physicalState existed does not describe it: not served
  if (thing.getThingDescription().properties?.["physicalState"]) {
    thing.setPropertyReadHandler("physicalState", read(() => physical() ?? { following: false, followed: 0 }));
  }
  thing.setPropertyReadHandler("getJointPosition", read(() => twin.jointsRecord()));
  thing.setPropertyReadHandler(
    "getCartesianPosition",
    read(() => {
      const p = twin.realPose();
      return { ...p.position, orientation: p.orientation };
    }),
  );
  thing.setPropertyReadHandler("motionStatus", read(() => twin.status));
  thing.setPropertyReadHandler("calibration", read(() => calibrationProperty(twin.folder.calibration)));

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
