/**
 * A relayed detour: the twin finds the straight joint path to a target blocked by a box only its scene
 * has, plans a detour, and relays it to an emulated robot (`robwot emulate`, which goes straight to what it
 * is told and does not know the box) as the detour's legs, one joint move each. The emulated robot's joints,
 * read throughout its motion, never touch the box (checked by the twin's backend, which first shows the
 * straight path it would have run touches it); the twin relays to it without `--follow` and still mirrors
 * it, and its safety monitor does not stop the validated motion.
 * Real emulator, servient, backends and HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulatedCell, type EmulatedCell } from "./helpers/emulated-cell.js";
import { boxOnJoint1Arc, generateTwin, http, invoke, kukaPose, sleep } from "./serve-helpers.js";

const START = kukaPose([0, 1.0, 0, -1.0, 0, 0.5, 0]);
const TARGET = kukaPose([1.2, 1.0, 0, -1.0, 0, 0.5, 0]);

let cell: EmulatedCell;

beforeAll(async () => {
  // the relaying twin mirrors the robot: it follows it to START
  cell = await startEmulatedCell({ start: START, folder: () => generateTwin("kuka_iiwa", 3000), twin: (td) => ({ relay: td }) });
  // a 0.3 m box where the tool is after 0.6 rad of joint 1, halfway to TARGET
  await boxOnJoint1Arc(cell.base, 0.6, 0.3);
}, 120_000);

afterAll(async () => cell?.stop());

it("relays a detour as its legs: the physical robot goes around the box, mirrored, and is not stopped", async () => {
  const { robot, twin, base, stream } = cell;
  const sim = twin.backend.sim;
  const robotId = twin.twins.get(twin.things[0]!.slug)!.robotId;
  // the reference catches the known positive: the straight path (what the target alone would make the robot run) touches the box
  const straight = await sim.checkPath({ robot: robotId, from: Object.values(START), target: Object.values(TARGET) });
  expect(straight.collisionFree).toBe(false);
  expect(straight.firstCollision!.contacts.some((c) => c.a.body === "fixture" || c.b.body === "fixture")).toBe(true);

  const seen: number[][] = [];
  let moving = true;
  const sampler = (async () => {
    while (moving) {
      seen.push(Object.values((await http(`${robot.tdUrl}/properties/getJointPosition`)).body as Record<string, number>));
      // the sampling period of the robot's way (each reading is checked below; no time is asserted)
      await sleep(5);
    }
  })();
  const r = await invoke(base, "moveToJointPosition", { joints: TARGET, speed: 1 });
  moving = false;
  await sampler;
  expect(r.status, JSON.stringify(r.body)).toBe(200);
  expect(r.body.path).toBe("detour");
  expect(r.body.relay.ok, JSON.stringify(r.body.relay)).toBe(true);
  expect(r.body.relay.legs).toBeGreaterThan(1);
  expect(r.body.relay.leg).toBe(r.body.relay.legs - 1);
  const q = (await http(`${robot.tdUrl}/properties/getJointPosition`)).body as Record<string, number>;
  for (const [j, v] of Object.entries(TARGET)) expect(q[j]).toBeCloseTo(v, 6);

  // every reading of the physical robot on its way, by the twin's backend: no contact with the box
  expect(seen.length).toBeGreaterThan(20);
  for (const [k, s] of seen.entries()) {
    const check = await sim.checkCollision({ robot: robotId, positions: s });
    expect(check.collisionFree, `reading ${k} of ${seen.length}: ${JSON.stringify(check.contacts)}`).toBe(true);
  }
  const state = (await http(`${base}/properties/physicalState`)).body;
  expect(state.following).toBe(true);
  expect(state.source).toBe(robot.tdUrl);
  expect(state.collisionImminent).toBe(0);
  expect(stream.messages.filter((m) => m.type === "collisionImminent")).toEqual([]);
}, 120_000);
