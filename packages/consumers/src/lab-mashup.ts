/**
 * Scenario 7: the RobWoT paper's mashup over the TUM IoT Remote Lab (its repository's
 * `DigitalTwinDemos/mashup_virtual_platform.ts`), written with node-wot against TDs shaped like the lab's
 * devices: the warehouse arm takes the cube from its store (`getCube`), conveyor 1 runs until infrared
 * sensor 2 sees the cube, the uArm opens its gripper, picks the cube (`goTo` in integer millimetres,
 * `gripClose`), shows it to the colour sensor (`color`), places it on conveyor 2, which runs back until
 * infrared sensor 1 sees it, and the warehouse arm returns it to the store (`returnCube`).
 *
 * Run against the remote-lab cell (examples/cells/remote-lab, README "A whole cell"): each device's TD is
 * fetched from BASE/<device> (`--uarm URL` and the others replace one). Against the lab itself only the
 * TD URLs change. Every action is awaited (a twin's move answers once it ended); the paper's waits after a
 * sensor fires (0.5 s and 0.6 s: the belt carries the cube on to its end) are kept, in simulated time:
 * divided by `--realtime` (the servient's factor; 0, as fast as possible: one tick of the cell's clock).
 * It prints each step and the cycle time; it fails (exit 1) on any refused action, a sensor that never
 * fires, or a colour sensor that sees nothing.
 *
 *   node packages/consumers/dist/lab-mashup.js [BASE URL] [--realtime 1] [--timeout 120] [--uarm URL] ... [--json]
 */
import { numberOption, parseArgs, stringOption } from "./lib/args.js";
import { invoke, openSession, read, type Twin } from "./lib/connect.js";
import { fmt, printJsonSummary } from "./lib/format.js";
import { runScenario } from "./lib/run.js";

const DEVICES = ["uarm", "warehouse", "conveyor1", "conveyor2", "infraredsensor1", "infraredsensor2", "colorsensor"] as const;
type Device = (typeof DEVICES)[number];
const USAGE = `lab-mashup [BASE URL] [--realtime 0|0.01..100] [--timeout S] ${DEVICES.map((d) => `[--${d} TD URL]`).join(" ")} [--json]`;

/** The paper's positions of the uArm (mm, its own frame). */
const START = { x: 150, y: 0, z: 70 };
const P1 = { x: 192, y: 192, z: 87 }; // above the end of conveyor 1
const P4 = { x: 192, y: 192, z: 52 }; // the cube's top there
const P3 = { x: 180, y: 0, z: 60 }; // before the colour sensor
const P2 = { x: 200, y: -200, z: 90 }; // above conveyor 2
const P6 = { x: 200, y: -200, z: 70 }; // where the cube is let go onto it
const P5 = { x: 200, y: 0, z: 80 }; // out of the way
/** ms of wall time between two readings of a sensor */
const POLL_MS = 100;
/** ms of wall time one tick of the cell's clock takes at --realtime 0 (its largest step) */
const FASTEST_WAIT_MS = 100;

interface Step {
  what: string;
  /** s since the mashup started */
  at: number;
}

const sleep = (ms: number): Promise<void> => new Promise((resolve) => setTimeout(resolve, ms));

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), {
    realtime: "value",
    timeout: "value",
    json: "flag",
    ...Object.fromEntries(DEVICES.map((d) => [d, "value" as const])),
  });
  const base = (args.positional[0] ?? process.env["ROBWOT_LAB"] ?? "http://127.0.0.1:8080").replace(/\/+$/, "");
  const realtime = numberOption(args, "realtime", 1, 0, 100);
  const timeoutMs = numberOption(args, "timeout", 120, 1, 3600) * 1000;
  /** a wait of the paper (ms of the lab's time) as wall time at the servient's realtime factor */
  const simulated = (ms: number): number => (realtime === 0 ? FASTEST_WAIT_MS : ms / realtime);
  const session = await openSession();
  const steps: Step[] = [];
  let t0 = Date.now(); // from the first step on: the cycle counts the mashup, not fetching the TDs
  const step = (what: string): void => {
    steps.push({ what, at: (Date.now() - t0) / 1000 });
    if (!args.options.has("json")) console.log(`${fmt((Date.now() - t0) / 1000, 1).padStart(6)} s  ${what}`);
  };
  try {
    const things = {} as Record<Device, Twin>;
    for (const d of DEVICES) things[d] = await session.connect(stringOption(args, d) ?? `${base}/${d}`);
    const { uarm, warehouse, conveyor1, conveyor2, colorsensor } = things;
    const detections = { infraredsensor1: 0, infraredsensor2: 0 };
    for (const s of ["infraredsensor1", "infraredsensor2"] as const) {
      await things[s].thing.subscribeEvent("detectedObject", () => void detections[s]++);
    }
    /** Until the sensor sees the cube: its `objectPresence` read, or a `detectedObject` event since `seen`
     *  (the count before the belt started). A reading is the cell's state at the end of a tick of its clock;
     *  at --realtime 0 a tick runs 1 s of the cell, in which the belt carries the cube through the beam and on
     *  (the event is raised within the tick, the reading after it), so the event is what cannot be missed. */
    const until = async (sensor: keyof typeof detections, seen: number, what: string): Promise<void> => {
      const deadline = Date.now() + timeoutMs;
      while (detections[sensor] === seen && !(await read<boolean>(things[sensor], "objectPresence"))) {
        if (Date.now() > deadline) throw new Error(`${what} never saw the cube within ${timeoutMs / 1000} s`);
        await sleep(POLL_MS);
      }
    };
    /** A belt run until a sensor sees the cube, then (the paper's wait later) stopped. */
    const carry = async (belt: Twin, start: string, beltName: string, sensor: keyof typeof detections, sensorName: string, waitMs: number): Promise<void> => {
      const seen = detections[sensor];
      await invoke(belt, start);
      await until(sensor, seen, sensorName);
      step(`${sensorName} sees the cube`);
      await sleep(simulated(waitMs));
      await invoke(belt, "stopBelt");
      step(`${beltName} stopped`);
    };
    const goTo = async (p: { x: number; y: number; z: number }, name: string): Promise<void> => {
      await invoke(uarm, "goTo", p);
      step(`uArm at ${name} (${p.x}, ${p.y}, ${p.z}) mm`);
    };

    t0 = Date.now();
    step("Starting Mashup");
    await goTo(START, "start");
    await invoke(warehouse, "getCube");
    step("warehouse: getCube (the cube on conveyor 1)");
    await carry(conveyor1, "startBeltForward", "conveyor 1", "infraredsensor2", "infrared sensor 2", 500);

    await invoke(uarm, "gripOpen");
    await goTo(P1, "P1");
    await goTo(P4, "P4");
    await invoke(uarm, "gripClose");
    step("uArm: gripClose");
    await goTo(P1, "P1");
    await goTo(P3, "P3");
    const color = await colourSeen(colorsensor, timeoutMs);
    step(`colour sensor: RGB (${color.r}, ${color.g}, ${color.b})`);
    await goTo(P2, "P2");
    await goTo(P6, "P6");
    await invoke(uarm, "gripOpen");
    step("uArm: gripOpen (the cube on conveyor 2)");
    await goTo(P5, "P5");

    await carry(conveyor2, "startBeltBackward", "conveyor 2", "infraredsensor1", "infrared sensor 1", 600);
    await invoke(warehouse, "returnCube");
    step("warehouse: returnCube (the cube back in its store)");
    const cycle = (Date.now() - t0) / 1000;
    if (args.options.has("json")) printJsonSummary({ cycle, color, detections, realtime, steps });
    else console.log(`cycle ${fmt(cycle, 2)} s (wall) at --realtime ${realtime}; detections: ${JSON.stringify(detections)}`);
  } finally {
    await session.close();
  }
}

/** The colour the sensor reads: read again until it sees something (its reading follows the cell's clock). */
async function colourSeen(sensor: Twin, timeoutMs: number): Promise<{ r: number; g: number; b: number }> {
  const deadline = Date.now() + timeoutMs;
  for (;;) {
    const c = await read<{ r: number; g: number; b: number } | null>(sensor, "color");
    if (c !== null) return c;
    if (Date.now() > deadline) throw new Error(`the colour sensor saw nothing within ${timeoutMs / 1000} s`);
    await sleep(POLL_MS);
  }
}

runScenario("lab-mashup", USAGE, main);
