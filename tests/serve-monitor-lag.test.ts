/**
 * The safety monitor and a robot that reports late: `robwot emulate` with `--lag 0.2` (its reported joints a
 * first-order lag of 0.2 s behind the true ones, no timestamp), a UR3 on a table the emulator does not know,
 * served with `--relay` (and so `--follow`) at the default horizon (0.2 s). Jogs of shoulder_lift_joint
 * toward the table, as a pendant would, are stopped by the monitor before contact: the robot's final joints,
 * once its report has caught up with them, are valid for the twin's own `validateJointPosition`. Real
 * emulator, servient, backends and HTTP.
 */
import { mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulatedCell, type EmulatedCell } from "./helpers/emulated-cell.js";
import { generateTwin, invoke, waitJoints, waitSettled } from "./serve-helpers.js";

const LAG = 0.2;
const START = { shoulder_pan_joint: 0, shoulder_lift_joint: -1.0, elbow_joint: 0, wrist_1_joint: -1.5, wrist_2_joint: -1.57, wrist_3_joint: 0 };
/** rad/s of shoulder_lift_joint toward the table, from START */
const SPEEDS = [0.5, 0.5, 0.5, 1.0];

let cell: EmulatedCell;

beforeAll(async () => {
  const dir = mkdtempSync(join(tmpdir(), "robwot-lag-"));
  const scene = join(dir, "table.json");
  writeFileSync(scene, JSON.stringify({ version: 1, name: "table", obstacles: [{ name: "table", shape: { type: "box", size: [1.6, 1.2, 0.04] }, position: [0, 0, -0.03] }] }));
  cell = await startEmulatedCell({
    start: START,
    folder: () => generateTwin("ur3", 3000, ["--scene", scene]),
    emulator: { lag: LAG },
    twin: (td) => ({ relay: td, followRate: 50 }),
  });
}, 180_000);

afterAll(async () => cell?.stop());

const imminent = (): any[] => cell.stream.messages.filter((m) => m.type === "collisionImminent");

it("a robot reporting 0.2 s late is stopped before the table, every jog", async () => {
  const { robot, base, stream } = cell;
  for (const [k, v] of SPEEDS.entries()) {
    expect((await invoke(robot.tdUrl, "moveToJointPosition", { joints: START, speed: 0.3 })).body.status).toBe("reached");
    await waitJoints(base, START);
    const before = imminent().length;
    const jog = await invoke(robot.tdUrl, "jog", { velocities: { shoulder_lift_joint: v }, duration: 3 / v });
    expect(jog.body.status, `jog ${k} at ${v} rad/s ran its whole course`).toBe("stopped");
    await stream.waitFor(() => imminent().length > before);
    const event = imminent()[before];
    expect(event.stopped).toBe(true);
    expect(event.contacts.some((c: any) => c.a.body === "table" || c.b.body === "table"), JSON.stringify(event.contacts)).toBe(true);
    // the emulator's report once it has caught up with the true joints
    const q = await waitSettled(robot.tdUrl);
    const check = await invoke(base, "validateJointPosition", { joints: q });
    console.log(`jog ${k} at ${v} rad/s: collisionImminent "in" ${event.in.toFixed(3)} s, stopped at shoulder_lift_joint ${q.shoulder_lift_joint!.toFixed(4)} rad, valid: ${check.body.valid}`);
    expect(check.body.valid, `jog ${k} at ${v} rad/s ended at ${q.shoulder_lift_joint}: ${JSON.stringify(check.body.reasons)}`).toBe(true);
  }
}, 300_000);
