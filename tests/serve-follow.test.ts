/**
 * `--follow`: the twin reads the physical robot's joints from its Thing (a second servient standing in
 * for it) into `physicalState`, and when the physical robot moves without a twin command (here: a client
 * of the physical Thing itself, as a pendant would) the twin is set to where it is. A physical Thing that
 * goes away is reported (`lastError`, a growing `age`), never hidden. Real servients, backends and HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { generateTwin, http, invoke, kukaPose, waitFor } from "./serve-helpers.js";

let physical: RunningServient;
let twin: RunningServient;
let pBase: string;
let base: string;

beforeAll(async () => {
  physical = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
  pBase = `${physical.url}/${physical.things[0]!.slug}`;
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: pBase, followRate: 30 });
  base = `${twin.url}/${twin.things[0]!.slug}`;
});
afterAll(async () => {
  await twin?.stop();
  await physical?.stop();
});

const state = async (): Promise<any> => (await http(`${base}/properties/physicalState`)).body;
const joints = async (b: string): Promise<Record<string, number>> => (await http(`${b}/properties/getJointPosition`)).body;

/** physicalState read between two clock readings: its `age` is the time since its `timestamp` then. */
async function stateWithAge(): Promise<any> {
  const asked = Date.now();
  const s = await state();
  const answered = Date.now();
  if (s.timestamp) {
    const at = Date.parse(s.timestamp);
    expect(s.age).toBeGreaterThanOrEqual((asked - at) / 1000);
    expect(s.age).toBeLessThanOrEqual((answered - at) / 1000);
  }
  return s;
}

it("shows the physical robot's joints, pose and age as physicalState", async () => {
  // a reading taken after the test began: the twin keeps reading
  const from = Date.now();
  const s = await waitFor(async () => {
    const v = await stateWithAge();
    return v.joints && Date.parse(v.timestamp) >= from ? v : null;
  }, { what: "a reading" });
  expect(s).toMatchObject({ following: true, source: pBase });
  expect(s.joints).toEqual(await joints(pBase));
  expect(typeof s.position.x).toBe("number");
  const td = (await http(base)).body;
  expect(td.properties.physicalState.observable).toBe(true);
  expect(td.properties.physicalState.properties.age.unit).toBe("s");
});

it("follows the physical robot when it moves without a twin command", async () => {
  const before = (await state()).followed as number;
  const target = kukaPose([0.6, 0.4, 0, -0.9, 0, 0.5, 0]);
  // a pendant-style move on the physical robot itself, not through the twin
  const sent = Date.now();
  const moved = invoke(pBase, "moveToJointPosition", { joints: target, speed: 0.5 });
  // while it moves, the twin's physicalState sees intermediate states, read after the move was sent
  const mid = await waitFor(async () => {
    const v = await stateWithAge();
    return v.joints && v.joints.lbr_iiwa_joint_1 > 0.05 && v.joints.lbr_iiwa_joint_1 < 0.55 ? v : null;
  }, { what: "an intermediate physical state" });
  expect(Date.parse(mid.timestamp)).toBeGreaterThanOrEqual(sent);
  expect((await moved).body.status).toBe("reached");
  await waitFor(async () => {
    const q = await joints(base);
    return Object.entries(target).every(([j, v]) => Math.abs((q[j] ?? NaN) - v) < 1e-6);
  }, { what: "the twin at the physical robot's target" });
  const after = await state();
  expect(after.followed).toBeGreaterThan(before);
  expect(Date.parse(after.lastFollowed)).toBeGreaterThanOrEqual(sent);
  // the twin's own pose property follows too
  const pose = (await http(`${base}/properties/getCartesianPosition`)).body;
  expect(Math.hypot(pose.x - after.position.x, pose.y - after.position.y, pose.z - after.position.z)).toBeLessThan(1e-6);
});

it("a twin without --follow answers following: false; --follow-rate alone is refused", async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  const alone = await startServient({ twins: [dir], port: 0, realtime: 0 });
  try {
    expect((await http(`${alone.url}/${alone.things[0]!.slug}/properties/physicalState`)).body).toEqual({ following: false, followed: 0 });
  } finally {
    await alone.stop();
  }
  const r = await runCli(["serve", dir, "--follow-rate", "10"]);
  expect(r.code).toBe(2); // a usage error
  expect(r.stderr).toContain("--follow-rate goes with --follow URL");
  const fast = await runCli(["serve", dir, "--follow", "http://127.0.0.1:9/x", "--follow-rate", "500"]);
  expect(fast.code).toBe(2);
  expect(fast.stderr).toMatch(/--follow-rate/);
});

it("a physical Thing that goes away is reported: lastError set, age growing", async () => {
  await physical.stop();
  const s = await waitFor(async () => {
    const v = await stateWithAge();
    return v.lastError ? v : null;
  }, { what: "the error" });
  expect(s.following).toBe(true);
  // no newer reading: the age keeps growing with the time since the last one
  const later = await waitFor(async () => {
    const v = await stateWithAge();
    return v.age > s.age ? v : null;
  }, { what: "a growing age" });
  expect(later.timestamp).toBe(s.timestamp);
});
