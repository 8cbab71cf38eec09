/**
 * The safety monitor of `--follow`: an emulated robot (`robwot emulate`, which does not know the scene) is
 * jogged through its own Thing, as a pendant would, toward a box only the twin's scene has. In every one of
 * 20 approaches at speeds from 0.2 to 2 rad/s the twin emits `collisionImminent` naming the box and the
 * emulated robot stops before it touches (its final joints checked by the twin's backend); 20 jogs away
 * from the box at the same speeds are never stopped. Real emulator, servient, backends and HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulatedCell, type EmulatedCell } from "./helpers/emulated-cell.js";
import { boxOnJoint1Arc, generateTwin, http, invoke, kukaPose, waitFor, waitJoints } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
const START = kukaPose([0, 1.0, 0, -1.0, 0, 0.5, 0]);
const SPEEDS = Array.from({ length: 20 }, (_, i) => 0.2 + (1.8 * i) / 19);

let cell: EmulatedCell;

beforeAll(async () => {
  cell = await startEmulatedCell({ start: START, folder: () => generateTwin("kuka_iiwa", 3000), twin: (td) => ({ follow: td, followRate: 50 }) });
  // the box is where the tool will be after 0.6 rad of joint 1
  await boxOnJoint1Arc(cell.base, 0.6, 0.12);
}, 120_000);

afterAll(async () => cell?.stop());

/** Until the twin (following the robot) stands at START. */
const atStart = (): Promise<void> => waitJoints(cell.base, START);

const physicalState = async (): Promise<any> => (await http(`${cell.base}/properties/physicalState`)).body;

/** physicalState once a reading that arrived after `since` (ms) is shown. The follower takes readings one
 *  at a time, so every reading that arrived before it has had its monitor verdict (and is counted in
 *  `collisionImminent`). */
const shownAfter = (since: number): Promise<any> =>
  waitFor(async () => {
    const s = await physicalState();
    return Date.parse(s.timestamp) > since && s;
  }, { what: "a later reading" });

/** Until the twin stands at START and its monitor has seen the robot stand still there: a reading newer
 *  than the one that brought it there (the velocity from the last two readings is zero). */
async function atRest(): Promise<void> {
  await atStart();
  await shownAfter(Date.parse((await physicalState()).timestamp));
}

const imminent = (): any[] => cell.stream.messages.filter((m) => m.type === "collisionImminent");

it("stops every approach toward the box only the twin knows, before contact; never a clear jog", async () => {
  const { robot, twin, stream } = cell;
  const sim = twin.backend.sim;
  const robotId = twin.twins.get(twin.things[0]!.slug)!.robotId;
  for (const [k, v] of SPEEDS.entries()) {
    expect((await invoke(robot.tdUrl, "moveToJointPosition", { joints: START })).body.status).toBe("reached");
    await atRest();
    const before = imminent().length;
    const jog = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: v }, duration: 3 / v });
    expect(jog.body.status, `approach ${k} at ${v.toFixed(2)} rad/s ran its whole jog`).toBe("stopped");
    // the event follows the stop's answer from the robot, which may come after the jog's
    await stream.waitFor(() => imminent().length > before);
    const events = imminent().slice(before);
    expect(events.length, `approach ${k}`).toBe(1);
    expect(events[0].stopped).toBe(true);
    expect(events[0].contacts.some((c: any) => c.a.body === "fixture" || c.b.body === "fixture")).toBe(true);
    const q = (await http(`${robot.tdUrl}/properties/getJointPosition`)).body as Record<string, number>;
    const check = await sim.checkCollision({ robot: robotId, positions: Object.values(q) });
    expect(check.collisionFree, `approach ${k} at ${v.toFixed(2)} rad/s touched: ${JSON.stringify(check.contacts)}`).toBe(true);
  }
  for (const [k, v] of SPEEDS.entries()) {
    // back at 0.5 rad/s: at full speed (10 rad/s) the monitor, extrapolating 0.2 s ahead, would rightly stop
    // a move that ends 0.45 rad short of the box
    const back = await invoke(robot.tdUrl, "moveToJointPosition", { joints: START, speed: 0.05 });
    expect(back.body.status, `back to START before clear jog ${k}: ${JSON.stringify(imminent().slice(-2))}`).toBe("reached");
    await atRest();
    const before = imminent().length;
    const jog = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: -v }, duration: 0.3 });
    expect(jog.body.status, `clear jog ${k} at ${v.toFixed(2)} rad/s was stopped`).toBe("reached");
    // every reading of the jog judged: none predicted a contact
    expect((await shownAfter(Date.now())).collisionImminent, `clear jog ${k} at ${v.toFixed(2)} rad/s`).toBe(SPEEDS.length);
    expect(imminent().length).toBe(before);
  }
}, 300_000);
