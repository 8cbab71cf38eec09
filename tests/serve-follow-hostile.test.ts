/**
 * `--follow` against a hostile physical Thing (`helpers/hostile-thing.ts`): a reading held unanswered makes
 * the safety monitor blind, which the twin says on every surface (physicalState.monitorFault,
 * motionStatus.lastError E_MONITOR_BLIND, the /live `physical` push, a process warning) and answers with a
 * stop, once per episode, 20 of 20; a stop never answered is reported, a TD fetch that hangs likewise; junk
 * readings (also huge ones) never move the twin and their errors stay short and are not pushed at the poll
 * rate; with `--relay-map` too. Real servient, backend and HTTP.
 */
import { mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { startHostileThing, type HostileThing } from "./helpers/hostile-thing.js";
import { generateTwin, http, KUKA_JOINTS, kukaPose, live, waitFor, type LiveClient } from "./serve-helpers.js";

const START = kukaPose([0.2, 0.5, 0, -1.0, 0, 0.5, 0]);
const EPISODES = 20;

let robot: HostileThing;
let twin: RunningServient;
let base: string;
let stream: LiveClient;
const warnings: Error[] = [];
const onWarning = (w: Error): void => void warnings.push(w);

beforeAll(async () => {
  process.on("warning", onWarning);
  robot = await startHostileThing({ joints: START });
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: robot.tdUrl, followRate: 50 });
  base = twin.things[0]!.tdUrl;
  stream = await live(`${twin.liveUrl}?thing=${twin.things[0]!.slug}`);
  await waitFor(async () => (await state()).joints, { what: "the first reading", intervalMs: 10 });
}, 120_000);

afterAll(async () => {
  process.off("warning", onWarning);
  stream?.close();
  await twin?.stop();
  await robot?.close();
});

const state = async (b = base): Promise<any> => (await http(`${b}/properties/physicalState`)).body;
const status = async (b = base): Promise<any> => (await http(`${b}/properties/motionStatus`)).body;

/** Until readings flow again: no fault, and a reading newer than now. */
async function seeing(b = base): Promise<void> {
  const now = Date.now();
  await waitFor(async () => {
    const s = await state(b);
    return !s.monitorFault && Date.parse(s.timestamp) > now;
  }, { what: "readings again", intervalMs: 10 });
}

it(`a hung reading: the monitor is blind on every surface and stops the robot, ${EPISODES} of ${EPISODES} episodes`, async () => {
  const detection: number[] = [];
  for (let k = 0; k < EPISODES; k++) {
    await seeing();
    const stops = robot.stops;
    const faults = (await state()).monitorFaults as number;
    const liveFrom = stream.messages.length;
    const from = robot.log.length;
    // the next reading is held until the test releases it (at most 10 s)
    robot.reading = { kind: "hang", until: "release", ms: 10_000, once: true };
    await waitFor(async () => robot.stops > stops, { what: `episode ${k}: a stop`, intervalMs: 10 });
    const s = await state();
    const log = robot.log.slice(from);
    const hung = log.find((e) => e.what === "read")!;
    const stop = log.find((e) => e.what === "stop")!;
    // the stop came while the reading was held
    expect(log.some((e) => e.what === "released"), `episode ${k}`).toBe(false);
    detection.push(stop.at - hung.at);
    expect(s.monitorFault, `episode ${k}: ${JSON.stringify(s)}`).toMatchObject({ code: "E_MONITOR_BLIND", reason: expect.stringMatching(/blind: no usable reading .* reading getJointPosition sent \d+ ms ago is unanswered/) });
    expect(s.monitorFaults).toBe(faults + 1);
    // blind since the last reading the twin shows
    expect(s.monitorFault.since).toBe(s.timestamp);
    expect((await status()).lastError?.code).toBe("E_MONITOR_BLIND");
    await stream.waitFor((m) => stream.messages.indexOf(m) >= liveFrom && m.type === "physical" && m.monitorFault?.code === "E_MONITOR_BLIND");
    robot.release();
    await seeing();
    expect((await status()).lastError).toBeUndefined();
    expect(robot.stops).toBe(stops + 1);
  }
  expect(warnings.filter((w) => (w as { code?: string }).code === "ROBWOT_MONITOR_BLIND").length).toBeGreaterThanOrEqual(EPISODES);
  // never a second reading beside a held one
  expect(robot.maxInFlight).toBe(1);
  const sorted = [...detection].sort((a, b) => a - b);
  console.log(`hung reading -> stop at the robot: median ${sorted[EPISODES >> 1]} ms, max ${sorted[EPISODES - 1]} ms over ${EPISODES} episodes (horizon 0.2 s, 50 Hz)`);
}, 300_000);

it("a stop never answered is reported in the fault, never awaited", async () => {
  await seeing();
  robot.stop = { kind: "hang" };
  robot.reading = { kind: "hang", until: "release" };
  const s = await waitFor(async () => {
    const v = await state();
    return v.monitorFault?.stop?.state === "failed" ? v : null;
  }, { what: "the stop's deadline", intervalMs: 10 });
  expect(s.monitorFault.stop.error).toMatch(/^the stop \(stop\) to the physical robot: no answer within 1000 ms$/);
  robot.stop = { kind: "ok" };
  robot.reading = { kind: "joints" };
  robot.release();
  await seeing();
});

it("junk and huge readings never move the twin; their errors are short and not pushed at the poll rate", async () => {
  await seeing();
  const before = (await http(`${base}/properties/getJointPosition`)).body;
  // within the outbound answer cap (1 MiB): the reading is parsed and refused by the follower
  const many = `{${KUKA_JOINTS.map((j) => `"${j}":0`).join(",")},${Array.from({ length: 50_000 }, (_, i) => `"k${i}":${i}`).join(",")}}`;
  const cases: [string, string, RegExp][] = [
    ["null", "null", /^getJointPosition: expected an object of joint name -> number, got null$/],
    ["a joint null", JSON.stringify({ ...START, lbr_iiwa_joint_2: null }), /^getJointPosition\.lbr_iiwa_joint_2: expected a finite number, got null$/],
    ["a joint a hex string", JSON.stringify({ ...START, lbr_iiwa_joint_2: "0x10" }), /got the string "0x10"$/],
    ["a joint missing", JSON.stringify({ ...START, lbr_iiwa_joint_7: undefined }), /missing joint\(s\) "lbr_iiwa_joint_7"$/],
    ["50,000 unknown keys", many, /^getJointPosition: 50000 unknown joint\(s\) "k0", "k1", "k2" and 49997 more/],
    ["a 400,000-element array", `[${Array(400_000).fill(0).join(",")}]`, /got an array of 400000 items$/],
    // past it, the transport cuts the answer (never buffered whole)
    ["a 10^6-element array", `[${Array(1_000_000).fill(0).join(",")}]`, /answer (of \d+ bytes is )?larger than 1048576/],
  ];
  for (const [what, body, error] of cases) {
    const from = stream.messages.length;
    const errors = (await state()).readingErrors as number;
    robot.reading = { kind: "junk", body };
    const s = await waitFor(async () => {
      const v = await state();
      return error.test(v.lastError ?? "") ? v : null;
    }, { what: what, intervalMs: 10 });
    expect(Buffer.byteLength(s.lastError), what).toBeLessThanOrEqual(1024);
    // junk for 50 readings or more: the first failure and the fault are pushed, then at most one push per
    // ERROR_PUSH_MS (follow.test.ts times that on a fake clock); a push per reading would be one per refusal.
    // The bound counts refusals, not wall time: a loaded machine polls (and so refuses) less often.
    await waitFor(async () => (await state()).readingErrors >= errors + 50, { what: `${what}: 50 readings refused` });
    const refused = ((await state()).readingErrors as number) - errors;
    // pushes after the first refused reading (a good reading still in flight when the junk began is pushed
    // at once, as it should be, and a loaded machine has more of them in flight)
    const pushed = stream.messages.slice(from).filter((m) => m.type === "physical" && ((m.readingErrors as number | undefined) ?? 0) > errors);
    expect(pushed.length, `${what}: ${pushed.length} pushes for ${refused} refused readings`).toBeLessThanOrEqual(4 + Math.ceil(refused / 10));
    for (const m of pushed) expect(JSON.stringify(m).length, what).toBeLessThan(4096);
    expect((await http(`${base}/properties/getJointPosition`)).body, what).toEqual(before);
    expect((await state()).joints, what).toEqual(before);
    robot.reading = { kind: "joints" };
    await seeing();
  }
}, 120_000);

it("a TD fetch that hangs is an error at its deadline and a monitor fault", async () => {
  const silent = await startHostileThing({ joints: START, title: "silent" });
  silent.td = { kind: "hang" };
  const other = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: silent.tdUrl, followRate: 50 });
  try {
    const b = other.things[0]!.tdUrl;
    const s = await waitFor(async () => {
      const v = await state(b);
      return v.monitorFault?.stop ? v : null;
    }, { what: "the fault", intervalMs: 10 });
    expect(s.lastError).toBe(`the TD at ${silent.tdUrl}: no answer within 2000 ms`);
    expect(s.monitorFault.reason).toMatch(/the TD at .* sent \d+ ms ago is unanswered/);
    expect(s.monitorFault.stop).toEqual({ state: "failed", error: expect.stringMatching(/was never read: no stop could be sent/) });
    expect((await status(b)).lastError.code).toBe("E_MONITOR_BLIND");
  } finally {
    await other.stop();
    await silent.close();
  }
});

it("with --relay-map, junk in the joint array never moves the twin; each error names the element", async () => {
  const order = [...KUKA_JOINTS].reverse();
  const deg = (rec: Record<string, number>): number[] => order.map((j) => ((rec[j] ?? 0) * 180) / Math.PI);
  const ur = await startHostileThing({ joints: deg(START), title: "ur", jointState: "actual_q", stopAction: "stopj" });
  const dir = mkdtempSync(join(tmpdir(), "robwot-hostile-map-"));
  writeFileSync(join(dir, "map.json"), JSON.stringify({ joints: order, unit: "deg", jointState: "actual_q", moveJoints: { action: "movej", joints: "q" }, stop: "stopj" }));
  const mapped = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, follow: ur.tdUrl, followRate: 50, relayMap: join(dir, "map.json") });
  try {
    const b = mapped.things[0]!.tdUrl;
    const q = (): Promise<Record<string, number>> => http(`${b}/properties/getJointPosition`).then((r) => r.body);
    await waitFor(async () => Math.abs(((await q())["lbr_iiwa_joint_1"] ?? 0) - 0.2) < 1e-9, { what: "the twin at the robot's pose", intervalMs: 10 });
    const before = await q();
    const good = deg(START);
    const junk: [unknown, RegExp][] = [
      [null, /^actual_q: expected an array of 7 numbers, got null$/],
      ["", /^actual_q: .* got the string ""$/],
      [[], /^actual_q: .* got an array of 0 items$/],
      [true, /^actual_q: .* got true$/],
      ["0x10", /^actual_q: .* got the string "0x10"$/],
      [good.map((v, i) => (i === 6 ? null : v)), /^actual_q\[6\]: lbr_iiwa_joint_1: expected a finite number, got null$/],
      [good.map((v, i) => (i === 6 ? "" : v)), /^actual_q\[6\]: .* got the string ""$/],
      [good.map((v, i) => (i === 6 ? [] : v)), /^actual_q\[6\]: .* got an array of 0 items$/],
      [good.map((v, i) => (i === 6 ? true : v)), /^actual_q\[6\]: .* got true$/],
      [good.map((v, i) => (i === 6 ? "0x10" : v)), /^actual_q\[6\]: .* got the string "0x10"$/],
      [[...good, 0], /^actual_q: .* got an array of 8 items$/],
    ];
    for (const [value, error] of junk) {
      ur.reading = { kind: "joints", value };
      const s = await waitFor(async () => {
        const v = await state(b);
        return error.test(v.lastError ?? "") ? v : null;
      }, { what: JSON.stringify(value), intervalMs: 10 });
      // two later readings refused as well: still where it was
      await waitFor(async () => (await state(b)).readingErrors >= s.readingErrors + 2, { what: `${JSON.stringify(value)}: later readings refused` });
      expect(await q(), JSON.stringify(value)).toEqual(before);
      expect(s.joints).toEqual(before);
    }
    // a good reading moves it
    ur.reading = { kind: "joints", value: deg({ ...START, lbr_iiwa_joint_1: 0.4 }) };
    await waitFor(async () => Math.abs(((await q())["lbr_iiwa_joint_1"] ?? 0) - 0.4) < 1e-9, { what: "the twin following a good reading", intervalMs: 10 });
  } finally {
    await mapped.stop();
    await ur.close();
  }
}, 120_000);
