/**
 * The cell's devices served as Things beside the twins (README "Conveyors and sensors as Things"): each
 * conveyor and each sensor of the shared world at `/<name>` (its scene name lowercased, other characters
 * than a-z 0-9 _ - as "-", made unique), with its TD from core (`td/cell-things.ts`), served by the router
 * as any twin (`ServedThing`: readproperty, invokeaction, SSE streams; listed by the directory) and
 * produced in node-wot for the long-poll observe and event routes.
 *
 * - Conveyor: `startBeltForward` / `startBeltBackward` / `stopBelt` = one `conveyor.set` each (idempotent:
 *   `changed: false` when the belt already was so), answered `{state, speed, changed}`; `state`, `speed`.
 * - Sensors: `objectPresence`, `object` (and `color` of a colour sensor, `{r, g, b}` or null) from the
 *   readings `cell.advance` answers; `detectedObject` / `objectLeft` events `{object, time}` from its events.
 *
 * The `CellClock` advances the cell while a belt runs; the objects it moves go to the `SceneRecord` (the
 * twins' `objects` property and /live `scene` follow). A restarted backend gets the belts back from the
 * record (`cell-record.ts`); the readings are read again then.
 */
import { EventEmitter } from "node:events";
import { randomUUID } from "node:crypto";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { BELT_SPEED_SCHEMA, CONVEYOR_ACTIONS, conveyorThingDescription, securityFor, sensorThingDescription, type ThingDescription } from "@robwot/core";
import type { BackendSupervisor, CellAdvanced, CellEvent, CellList, Conveyor, ConveyorState, SensorReading } from "@robwot/sim-client";
import { ActionStatusStore } from "./action-status.js";
import { registerReaders, type ActionHandler } from "./affordance-routes.js";
import type { AuthConfig } from "./auth.js";
import { CellClock } from "./cell-clock.js";
import type { ServedThing } from "./http-middleware.js";
import type { SceneRecord } from "./scene-record.js";
import type { SseSource } from "./sse.js";
import { produceInit } from "./thing-td.js";
import type { TdDocument } from "./twin-folder.js";

export interface CellEnv {
  wot: typeof WoT;
  backend: BackendSupervisor;
  world: SceneRecord;
  realtime: number;
  url: string;
  auth: AuthConfig | undefined;
  /** the servient's own URL path segments (the Things served already take theirs too) */
  reserved: readonly string[];
}

/** A device as `robwot.json` and the banner may list it. */
export interface CellDeviceInfo {
  name: string;
  kind: "conveyor" | "presence" | "color";
  path: string;
  tdUrl: string;
}

export interface ExposedCell {
  served: Map<string, ServedThing>;
  devices: CellDeviceInfo[];
  clock: CellClock;
  stop(): Promise<void>;
}

/** The cell's live state in the servient: the belts and the sensors' readings, their changes and events. */
class CellState extends EventEmitter<{ changed: [device: string]; event: [CellEvent] }> {
  readonly conveyors = new Map<string, Conveyor>();
  readonly readings = new Map<string, SensorReading>();

  conveyor(c: Conveyor): void {
    const before = this.conveyors.get(c.name);
    this.conveyors.set(c.name, c);
    if (before?.state !== c.state || before?.speed !== c.speed) this.emit("changed", c.name);
  }

  reading(r: SensorReading): void {
    const before = this.readings.get(r.name);
    this.readings.set(r.name, r);
    if (JSON.stringify(before) !== JSON.stringify(r)) this.emit("changed", r.name);
  }

  running(): boolean {
    return [...this.conveyors.values()].some((c) => c.state !== "stopped");
  }
}

/** A colour reading as the TD states it. */
function rgb(r: SensorReading | undefined): { r: number; g: number; b: number } | null {
  const c = r?.color;
  return Array.isArray(c) && c.length === 3 ? { r: c[0]!, g: c[1]!, b: c[2]! } : null;
}

/** Each device's URL path segment: its name lowercased, every run of characters other than a-z 0-9 _ -
 *  one "-" (what node-wot's route of a Thing with that title is), `_2`, `_3`, ... after a taken one. */
function devicePaths(names: string[], taken: ReadonlySet<string>): Map<string, string> {
  const used = new Set(taken);
  const paths = new Map<string, string>();
  for (const name of names) {
    const plain = name.toLowerCase().replace(/[^a-z0-9_-]+/g, "-").replace(/^-+|-+$/g, "").slice(0, 64) || "device";
    let path = plain;
    for (let n = 2; used.has(path); n++) path = `${plain}_${n}`;
    used.add(path);
    paths.set(name, path);
  }
  return paths;
}

/** Whether the cell's clock runs: some belt runs, or a robot holds an object and some sensor may see it. */
function cellRuns(env: CellEnv, state: CellState): boolean {
  return state.running() || (env.world.holding && env.world.cell.sensors.size > 0);
}

/** The cell's state from the backend's listing, kept up to date by the clock and after a restart. */
async function runCell(env: CellEnv): Promise<{ state: CellState; clock: CellClock; listing: CellList; stop(): Promise<void> }> {
  const state = new CellState();
  state.setMaxListeners(0);
  // a world without conveyors and sensors costs no call (and needs no backend that knows the cell)
  const empty = env.world.cell.conveyors.size === 0 && env.world.cell.sensors.size === 0;
  const listing: CellList = empty ? { time: 0, conveyors: [], sensors: [] } : await env.backend.sim.listCell();
  const listed = (l: CellList): void => {
    for (const c of l.conveyors) {
      state.conveyor(c);
      env.world.cell.conveyorSet(c);
    }
    for (const s of l.sensors) state.reading(s.reading);
  };
  listed(listing);
  const clock = new CellClock(env.backend, {
    realtime: env.realtime,
    onAdvanced: (r: CellAdvanced) => {
      env.world.movedByCell(r.moved);
      for (const s of r.sensors) state.reading(s);
      for (const e of r.events) state.emit("event", e);
    },
    onError: (err) => process.emitWarning(`robwot serve: cell.advance failed: ${err instanceof Error ? err.message : String(err)}`, { code: "ROBWOT_CELL_CLOCK" }),
  });
  // a restarted backend has the belts as recorded: the readings read again, the clock resumed
  const onUp = (): void => {
    clock.resume();
    if (!empty) env.backend.sim.listCell().then(listed, () => undefined);
  };
  env.backend.on("up", onUp);
  // a robot carrying an object past a sensor changes its reading: the clock also runs while one holds one
  const onScene = (): void => clock.setRunning(cellRuns(env, state));
  env.world.on("scene", onScene);
  clock.setRunning(cellRuns(env, state));
  return {
    state,
    clock,
    listing,
    stop: async () => {
      env.backend.off("up", onUp);
      env.world.off("scene", onScene);
      await clock.stop();
    },
  };
}

type DeviceParts = Pick<ServedThing, "affordances" | "observe">;

/** The conveyors and sensors of the world as Things, each added to `things` (the router's, by path; the
 *  twins and an `--as` device already there keep theirs) and produced in node-wot (its long-poll observe
 *  and event routes), and the clock that runs them. */
export async function exposeCell(env: CellEnv, things: Map<string, ServedThing>): Promise<ExposedCell> {
  const cell = await runCell(env);
  const { state, clock, listing } = cell;
  const paths = devicePaths([...listing.conveyors.map((c) => c.name), ...listing.sensors.map((s) => s.name)], new Set([...things.keys(), ...env.reserved]));
  const served = new Map<string, ServedThing>();
  // the router's file routes look into a Thing's folder: a device has none (a path that does not exist)
  const noFiles = join(tmpdir(), `robwot-cell-no-files-${randomUUID()}`);
  const devices: CellDeviceInfo[] = [];
  const place = async (name: string, kind: CellDeviceInfo["kind"], td: ThingDescription, parts: DeviceParts): Promise<void> => {
    const path = paths.get(name)!;
    const secured = securityFor(td, env.auth ? { scheme: env.auth.scheme } : null) as unknown as Record<string, unknown>;
    served.set(path, { slug: path, dir: noFiles, urdfName: join(".robwot-none", "none"), td: () => secured, actionInput: (a) => (a in td.actions ? undefined : null), statuses: new ActionStatusStore(), ...parts });
    await produce(env.wot, state, name, path, td, parts.affordances.properties);
    devices.push({ name, kind, path, tdUrl: `${env.url}/${path}` });
  };
  for (const c of listing.conveyors) {
    await place(c.name, "conveyor", conveyorThingDescription(c, { baseUrl: env.url, path: paths.get(c.name)! }), conveyorThing(env, state, clock, c.name));
  }
  for (const s of listing.sensors) {
    await place(s.name, s.kind, sensorThingDescription(s, { baseUrl: env.url, path: paths.get(s.name)! }), sensorThing(state, s.name, s.kind === "color"));
  }
  for (const [path, thing] of served) things.set(path, thing);
  return { served, devices, clock, stop: cell.stop };
}

/** The device in node-wot at `/<path>` (its title there is the path: node-wot's route is its slug): its
 *  long-poll observers re-read the readers on each change, its events emitted. */
async function produce(wot: typeof WoT, state: CellState, name: string, path: string, td: ThingDescription, readers: Map<string, () => unknown>): Promise<void> {
  const init = produceInit({ ...(td as unknown as TdDocument), title: path });
  const thing = await wot.produce(init);
  registerReaders(thing, readers);
  // node-wot's emitPropertyChange returns a promise at run time (typed void): never leave it unhandled
  const change = (property: string): void => void Promise.resolve(thing.emitPropertyChange(property) as unknown).catch(() => undefined);
  state.on("changed", (device) => {
    if (device === name) for (const property of readers.keys()) change(property);
  });
  if (Object.keys(td.events).length > 0) {
    state.on("event", (e) => {
      if ((e.type !== "detectedObject" && e.type !== "objectLeft") || e.sensor !== name) return;
      try {
        thing.emitEvent(e.type, { object: e.object, time: e.time });
      } catch {
        /* a failing long-poll subscriber must not take the clock's path down */
      }
    });
  }
  await thing.expose();
}

/** A property's SSE source: its reader's value after each change of the device. */
function changes(state: CellState, device: string, read: () => unknown): SseSource {
  return {
    current: read,
    subscribe: (send) => {
      const listener = (name: string): void => {
        if (name === device) send(read());
      };
      state.on("changed", listener);
      return () => void state.off("changed", listener);
    },
  };
}

function conveyorThing(env: CellEnv, state: CellState, clock: CellClock, name: string): DeviceParts {
  const belt = (): Conveyor => state.conveyors.get(name)!;
  const set = async (to: ConveyorState, speed?: number): Promise<{ state: ConveyorState; speed: number; changed: boolean }> => {
    const { conveyor, changed } = await env.backend.sim.setConveyor({ name, state: to, ...(speed !== undefined ? { speed } : {}) });
    env.world.cell.conveyorSet(conveyor);
    state.conveyor(conveyor);
    clock.setRunning(cellRuns(env, state));
    return { state: conveyor.state, speed: conveyor.speed, changed };
  };
  const properties = new Map<string, () => unknown>([
    ["speed", () => belt().speed],
    ["state", () => belt().state],
  ]);
  const actions = new Map<string, ActionHandler>(Object.entries(CONVEYOR_ACTIONS).map(([action, to]) => [action, () => set(to)]));
  // the speed written (checked against the contract's range by the router), the belt in its state
  const writers = new Map([["speed", { schema: BELT_SPEED_SCHEMA, write: async (v: unknown) => void (await set(belt().state, v as number)) }]]);
  return {
    affordances: { properties, actions, writers },
    observe: (kind, property) => (kind === "properties" && properties.has(property) ? changes(state, name, properties.get(property)!) : null),
  };
}

function sensorThing(state: CellState, name: string, color: boolean): DeviceParts {
  const reading = (): SensorReading | undefined => state.readings.get(name);
  const properties = new Map<string, () => unknown>([
    ["objectPresence", () => reading()?.objectPresence ?? false],
    ["object", () => reading()?.object ?? null],
    ...(color ? [["color", () => rgb(reading())] as [string, () => unknown]] : []),
  ]);
  const events = (type: "detectedObject" | "objectLeft"): SseSource => ({
    subscribe: (send) => {
      const listener = (e: CellEvent): void => {
        if (e.type === type && e.sensor === name) send({ object: e.object, time: e.time });
      };
      state.on("event", listener);
      return () => void state.off("event", listener);
    },
  });
  return {
    affordances: { properties, actions: new Map() },
    observe: (kind, n) => {
      if (kind === "events") return n === "detectedObject" || n === "objectLeft" ? events(n) : null;
      const read = properties.get(n);
      return read ? changes(state, name, read) : null;
    },
  };
}
