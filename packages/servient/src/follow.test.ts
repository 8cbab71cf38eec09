/**
 * The follower and its safety monitor in-process: a fake physical Thing (the `FollowWoT` node-wot part), a
 * fake backend (FK = the joints, a wall at joint 1 = `WALL`) and vitest's fake clock, so every deadline, skip
 * and fault is a deterministic function of simulated time.
 */
import type { BackendSupervisor } from "@robwot/sim-client";
import { afterEach, beforeEach, describe, expect, it, vi } from "vitest";
import { ERROR_PUSH_MS, Follower, type FollowOptions, MONITOR_BLIND, type PhysicalState } from "./follow.js";
import { MAX_ERROR_TEXT } from "./reading.js";
import type { RelayMap } from "./relay-map.js";
import { type CollisionImminentEvent, Twin } from "./twin.js";
import type { TwinFolder } from "./twin-folder.js";

const JOINTS = ["j1", "j2"];
/** rad: joint 1 at or beyond this touches the wall */
const WALL = 1;
/** rad/s: both joints' velocity limit (acceleration: reached in the contract's 0.25 s) */
const VMAX = 2;
const T0 = Date.parse("2026-03-01T00:00:00Z");

interface Deferred<T> {
  promise: Promise<T>;
  resolve(v: T): void;
  reject(e: unknown): void;
}
function deferred<T>(): Deferred<T> {
  let resolve!: (v: T) => void;
  let reject!: (e: unknown) => void;
  const promise = new Promise<T>((res, rej) => ((resolve = res), (reject = rej)));
  return { promise, resolve, reject };
}

/** The physical Thing: `answer` gives each reading (a value, or a promise of one); its stop is `stopAnswer`. */
class FakeThing {
  reads = 0;
  inFlight = 0;
  maxInFlight = 0;
  stops: string[] = [];
  answer: () => unknown = () => ({ j1: 0, j2: 0 });
  stopAnswer: () => Promise<unknown> = async () => ({ stopped: true });

  async readProperty(_name: string): Promise<{ value(): Promise<unknown> }> {
    this.reads++;
    this.inFlight++;
    this.maxInFlight = Math.max(this.maxInFlight, this.inFlight);
    try {
      const v = await this.answer();
      return { value: async () => v };
    } finally {
      this.inFlight--;
    }
  }

  invokeAction(name: string): Promise<unknown> {
    this.stops.push(name);
    return this.stopAnswer();
  }
}

function harness(options: Partial<FollowOptions> = {}, td: () => Promise<unknown> = async () => ({ title: "arm" })) {
  const thing = new FakeThing();
  const wot = { requestThingDescription: td, consume: async () => thing };
  const fk: number[][] = [];
  const sets: number[][] = [];
  const paths: { from: number[]; target: number[] }[] = [];
  const backend = {
    isUp: true,
    sim: {
      fk: async ({ positions: q = [] }: { positions?: number[] }) => (fk.push([...q]), { position: [q[0] ?? 0, q[1] ?? 0, 0], orientation: [0, 0, 0, 1], link: "ee" }),
      setJointPositions: async ({ positions: q }: { positions: number[] }) => (sets.push([...q]), { names: JOINTS, positions: q }),
      checkCollision: async ({ positions: q = [] }: { positions?: number[] }) => ({ collisionFree: (q[0] ?? 0) < WALL, contacts: [] }),
      checkPath: async ({ from, target }: { from: number[]; target: number[] }) => {
        paths.push({ from: [...from], target: [...target] });
        const [a, b] = [from[0] ?? 0, target[0] ?? 0];
        if (Math.max(a, b) < WALL) return { collisionFree: true, duration: 0, steps: 1 };
        const f = a >= WALL ? 0 : (WALL - a) / (b - a);
        const positions = from.map((v, i) => v + f * ((target[i] ?? v) - v));
        return { collisionFree: false, duration: 0, steps: 1, firstCollision: { time: 0, positions, contacts: [{ a: { body: "arm" }, b: { body: "wall" } }] } };
      },
    },
  } as unknown as BackendSupervisor;
  const folder = { calibration: null, manifest: { robot: {} } } as unknown as TwinFolder;
  const twin = new Twin("arm", folder, backend);
  twin.model = {
    name: "arm",
    eeLink: "ee",
    controllable: JOINTS,
    joints: JOINTS.map((name) => ({ name, type: "revolute" as const, lower: -3, upper: 3, velocity: VMAX, effort: 1 })),
  };
  twin.q = [0, 0];
  const events: CollisionImminentEvent[] = [];
  twin.on("collisionImminent", (e) => events.push(e));
  let pushes = 0;
  const follower = new Follower(wot, "http://robot.test/arm", twin, backend, { rate: 50, horizon: 0.2, ...options }, () => pushes++);
  return { follower, twin, thing, fk, sets, paths, events, pushes: () => pushes, view: (): PhysicalState => follower.view() };
}

type Harness = ReturnType<typeof harness>;
const run = (ms: number): Promise<void> => vi.advanceTimersByTimeAsync(ms).then(() => undefined);
/** ms of the fake clock when the last usable reading arrived */
const lastGood = (h: Harness): number => Date.parse(h.view().timestamp ?? "");

let warnings: { message: string; code: string | undefined }[];
beforeEach(() => {
  vi.useFakeTimers({ now: T0 });
  warnings = [];
  vi.spyOn(process, "emitWarning").mockImplementation(((w: string | Error, o?: { code?: string }) => {
    warnings.push({ message: String(w), code: o?.code });
  }) as typeof process.emitWarning);
});
afterEach(() => {
  vi.useRealTimers();
  vi.restoreAllMocks();
});

describe("deadlines and one request in flight", () => {
  it("a hung reading is an error at its deadline; no second request beside it; polling resumes once it ends", async () => {
    const h = harness({ monitor: "off", readDeadlineMs: 200 });
    h.follower.start();
    await run(100);
    expect(h.view().joints).toEqual({ j1: 0, j2: 0 });
    const gate = deferred<unknown>();
    h.thing.answer = () => gate.promise;
    const reads = h.thing.reads;
    await run(20); // the next poll sends the reading that hangs
    expect(h.thing.reads).toBe(reads + 1);
    const sent = Date.now();
    await run(199);
    expect(h.view().lastError).toBeUndefined();
    await run(2);
    expect(h.view().lastError).toMatch(/^reading getJointPosition: no answer within 200 ms$/);
    const skipped = h.view().skippedPolls!;
    await run(1_000);
    // still pending: every poll skipped and counted, nothing sent beside it
    expect(h.thing.reads).toBe(reads + 1);
    expect(h.thing.maxInFlight).toBe(1);
    expect(h.view().skippedPolls).toBeGreaterThanOrEqual(skipped + 1_000 / 20 - 1);
    expect(Date.now() - sent).toBeGreaterThan(1_000);
    // the hung request ends (the HTTP client's own deadline, or a late answer): the next poll reads again
    h.thing.answer = () => ({ j1: 0.3, j2: 0 });
    gate.resolve({ j1: 0.2, j2: 0 });
    await run(40);
    expect(h.thing.reads).toBeGreaterThan(reads + 1);
    expect(h.view().lastError).toBeUndefined();
    // the late answer is stale: never shown
    expect(h.view().joints).toEqual({ j1: 0.3, j2: 0 });
    expect(h.fk.some((q) => q[0] === 0.2)).toBe(false);
    h.follower.stop();
  });

  it("a hung TD fetch is an error at its deadline and, with the monitor on, a fault whose stop cannot be sent", async () => {
    const gate = deferred<unknown>();
    const h = harness({ connectDeadlineMs: 2_000 }, () => gate.promise);
    h.follower.start();
    await run(1_999);
    expect(h.view().lastError).toBeUndefined();
    await run(2);
    expect(h.view().lastError).toBe("the TD at http://robot.test/arm: no answer within 2000 ms");
    expect(h.view().monitorFault).toBeUndefined();
    // from start, the TD's deadline and then the horizon + one poll period (220 ms) without a reading
    await run(2_219 - (Date.now() - T0));
    expect(h.view().monitorFault).toBeUndefined();
    await run(1);
    const fault = h.view().monitorFault!;
    expect(fault.code).toBe(MONITOR_BLIND);
    expect(Date.parse(fault.since)).toBe(T0);
    expect(fault.reason).toMatch(/the TD at http:\/\/robot\.test\/arm sent \d+ ms ago is unanswered/);
    await run(1);
    expect(h.view().monitorFault!.stop).toEqual({ state: "failed", error: expect.stringMatching(/TD .* was never read: no stop could be sent/) });
    expect(h.thing.stops).toEqual([]);
    h.follower.stop();
  });
});

describe("blind: no usable reading for longer than the horizon + one poll period", () => {
  it.each([["stop" as const], ["warn" as const]])("mode %s: a fault on every surface once per episode, the robot stopped only in mode stop", async (mode) => {
    const h = harness({ monitor: mode });
    h.follower.start();
    await run(200);
    expect(h.view()).toMatchObject({ monitor: mode, monitorFaults: 0 });
    for (let episode = 1; episode <= 2; episode++) {
      const gate = deferred<unknown>();
      h.thing.answer = () => gate.promise;
      await run(20);
      const seen = lastGood(h);
      await run(seen + 219 - Date.now());
      expect(h.view().monitorFault).toBeUndefined();
      const pushes = h.pushes();
      await run(1);
      const fault = h.view().monitorFault!;
      expect(fault).toMatchObject({ code: MONITOR_BLIND, since: new Date(seen).toISOString() });
      expect(Date.parse(fault.detected) - seen).toBe(220);
      expect(fault.reason).toMatch(/blind: no usable reading of the physical robot for \d+ ms .*reading getJointPosition sent \d+ ms ago is unanswered/);
      expect(h.twin.status.lastError).toEqual({ code: MONITOR_BLIND, message: fault.reason });
      expect(h.pushes()).toBeGreaterThan(pushes);
      expect(warnings.filter((w) => w.code === "ROBWOT_MONITOR_BLIND")).toHaveLength(episode);
      await run(2_000);
      // once per episode, however long it lasts
      expect(h.thing.stops).toEqual(mode === "stop" ? Array(episode).fill("stop") : []);
      expect(h.view().monitorFault?.stop).toEqual(mode === "stop" ? { state: "answered" } : undefined);
      expect(h.view().monitorFaults).toBe(episode);
      h.thing.answer = () => ({ j1: 0, j2: 0 });
      gate.resolve({ j1: 0, j2: 0 });
      await run(60);
      expect(h.view().monitorFault).toBeUndefined();
      expect(h.twin.status.lastError).toBeUndefined();
    }
    h.follower.stop();
  });

  it("a fault right after another one's answered stop sends its own stop", async () => {
    const h = harness({ monitor: "stop", stopDeadlineMs: 1_000 });
    h.follower.start();
    await run(100);
    for (let episode = 1; episode <= 3; episode++) {
      const gate = deferred<unknown>();
      h.thing.answer = () => gate.promise;
      await run(280);
      expect(h.view().monitorFaults).toBe(episode);
      expect(h.thing.stops).toHaveLength(episode);
      h.thing.answer = () => ({ j1: 0, j2: 0 });
      gate.resolve({ j1: 0, j2: 0 });
      await run(40);
      expect(h.view().monitorFault).toBeUndefined();
    }
    h.follower.stop();
  });

  it("mode off: readings that fail are shown, never a fault", async () => {
    const h = harness({ monitor: "off" });
    h.follower.start();
    await run(100);
    h.thing.answer = () => new Promise(() => undefined);
    await run(3_000);
    expect(h.view().lastError).toMatch(/no answer within/);
    expect(h.view().monitorFault).toBeUndefined();
    expect(h.twin.status.lastError).toBeUndefined();
    h.follower.stop();
  });

  it("a stop never answered is reported at its deadline; the next fault sends another", async () => {
    const h = harness({ monitor: "stop", stopDeadlineMs: 1_000 });
    h.thing.stopAnswer = () => new Promise(() => undefined);
    h.follower.start();
    await run(100);
    const gate = deferred<unknown>();
    h.thing.answer = () => gate.promise;
    await run(400);
    expect(h.view().monitorFault?.stop).toEqual({ state: "pending" });
    await run(1_000);
    expect(h.view().monitorFault?.stop).toEqual({ state: "failed", error: "the stop (stop) to the physical robot: no answer within 1000 ms" });
    expect(h.thing.stops).toHaveLength(1);
    // the robot is seen again, then lost again: a new stop, past the first one's deadline
    h.thing.answer = () => ({ j1: 0, j2: 0 });
    gate.reject(new Error("socket hang up"));
    await run(100);
    expect(h.view().monitorFault).toBeUndefined();
    h.thing.answer = () => new Promise(() => undefined);
    await run(400);
    await run(1_000);
    expect(h.view()).toMatchObject({ monitorFaults: 2, monitorFault: { stop: { state: "failed", error: "the stop (stop) to the physical robot: no answer within 1000 ms" } } });
    expect(h.thing.stops).toHaveLength(2);
    h.follower.stop();
  });
});

describe("strict readings", () => {
  const many = Object.fromEntries(Array.from({ length: 200_000 }, (_, i) => [`k${i}`, i]));
  it.each([
    ["null", null, /^getJointPosition: expected an object of joint name -> number, got null$/],
    ["an empty string", "", /got the string ""$/],
    ["an array", [], /got an array of 0 items$/],
    ["true", true, /got true$/],
    ["a hex string", "0x10", /got the string "0x10"$/],
    ["a joint as a hex string", { j1: "0x10", j2: 0 }, /^getJointPosition\.j1: expected a finite number, got the string "0x10"$/],
    ["a joint null", { j1: null, j2: 0 }, /^getJointPosition\.j1: .* got null$/],
    ["a joint as an empty array", { j1: [], j2: 0 }, /^getJointPosition\.j1: .* got an array of 0 items$/],
    ["a joint true", { j1: true, j2: 0 }, /^getJointPosition\.j1: .* got true$/],
    ["a joint NaN", { j1: NaN, j2: 0 }, /^getJointPosition\.j1: .* got NaN$/],
    ["a joint an object", { j1: {}, j2: 0 }, /^getJointPosition\.j1: .* got an object of 0 key\(s\)$/],
    ["a joint missing", { j1: 0 }, /^getJointPosition: missing joint\(s\) "j2"$/],
    ["an extra joint", { j1: 0, j2: 0, j3: 0 }, /^getJointPosition: 1 unknown joint\(s\) "j3"; the twin's joints are "j1", "j2"$/],
    ["200,000 unknown keys", { j1: 0, j2: 0, ...many }, /^getJointPosition: 200000 unknown joint\(s\) "k0", "k1", "k2" and 199997 more;/],
    ["a 10^6-element array", Array.from({ length: 1_000_000 }, () => 0), /got an array of 1000000 items$/],
    ["a joint as a 10^6-character string", { j1: "x".repeat(1_000_000), j2: 0 }, /got the string "x{40}"\.\.\. \(1000000 characters\)$/],
    ["a bad timestamp", { j1: 0, j2: 0, timestamp: "yesterday" }, /^getJointPosition\.timestamp: expected an ISO 8601 date-time, got the string "yesterday"$/],
    ["a joint far past its limit", { j1: 3.5, j2: 0 }, /^getJointPosition\.j1: 3\.5 rad is beyond its limits \[-3, 3\] by more than 0\.02 rad/],
  ])("refuses %s: an error naming the field, never a pose", async (_what, junk, error) => {
    const h = harness({ monitor: "off" });
    h.thing.answer = () => ({ j1: 0.5, j2: 0.1 });
    h.follower.start();
    await run(100);
    const good = h.view();
    h.thing.answer = () => junk;
    await run(100);
    const v = h.view();
    expect(v.lastError).toMatch(error);
    expect(Buffer.byteLength(v.lastError!)).toBeLessThanOrEqual(MAX_ERROR_TEXT);
    expect(v.joints).toEqual(good.joints);
    expect(v.readingErrors).toBeGreaterThan(0);
    expect(h.fk.every((q) => q[0] === 0.5 && q[1] === 0.1)).toBe(true);
    expect(h.twin.q).toEqual([0.5, 0.1]);
    h.follower.stop();
  });

  const MAP: RelayMap = { joints: ["j2", "j1"], unit: "deg", jointState: "actual_q", moveJoints: { action: "movej", joints: "q" }, stop: "stopj" };
  it.each([
    ["null", null, /^actual_q: expected an array of 2 numbers, got null$/],
    ["an empty string", "", /^actual_q: .* got the string ""$/],
    ["an empty array", [], /^actual_q: expected an array of 2 numbers \(the map's joints\), got an array of 0 items$/],
    ["an object", { j1: 0, j2: 0 }, /^actual_q: .* got an object of 2 key\(s\)$/],
    ["null in it", [null, 0], /^actual_q\[0\]: j2: expected a finite number, got null$/],
    ["an empty string in it", [0, ""], /^actual_q\[1\]: j1: expected a finite number, got the string ""$/],
    ["an array in it", [[], 0], /^actual_q\[0\]: j2: .* got an array of 0 items$/],
    ["true in it", [true, 0], /^actual_q\[0\]: j2: .* got true$/],
    ["a hex string in it", ["0x10", 0], /^actual_q\[0\]: j2: .* got the string "0x10"$/],
    ["NaN in it", [0, NaN], /^actual_q\[1\]: j1: .* got NaN$/],
    ["a joint too many", [0, 0, 0], /^actual_q: .* got an array of 3 items$/],
    ["a 10^6-element array", Array.from({ length: 1_000_000 }, () => 0), /got an array of 1000000 items$/],
  ])("with a relay map refuses %s: an error naming the field, never a pose", async (_what, junk, error) => {
    const h = harness({ monitor: "off", map: MAP });
    h.thing.answer = () => [10, 20];
    h.follower.start();
    await run(100);
    expect(h.view().joints!.j1).toBeCloseTo((20 * Math.PI) / 180, 12);
    h.thing.answer = () => junk;
    await run(100);
    expect(h.view().lastError).toMatch(error);
    expect(Buffer.byteLength(h.view().lastError!)).toBeLessThanOrEqual(MAX_ERROR_TEXT);
    expect(h.view().joints!.j2).toBeCloseTo((10 * Math.PI) / 180, 12);
    expect(new Set(h.fk.map((q) => q.join()))).toHaveLength(1);
    h.follower.stop();
  });

  it("a joint a little past its limit is followed clamped and noted; readings that fail are pushed at most once a second", async () => {
    const h = harness({ monitor: "off" });
    h.thing.answer = () => ({ j1: 3.01, j2: -3.015 });
    h.follower.start();
    await run(100);
    expect(h.view()).toMatchObject({ joints: { j1: 3, j2: -3 }, clamped: { j1: 3.01, j2: -3.015 } });
    expect(h.view().lastError).toBeUndefined();
    expect(h.twin.q).toEqual([3, -3]);
    // the same junk at 50 Hz for 5 s: the first failure is pushed, then one push per ERROR_PUSH_MS
    h.thing.answer = () => ({ j1: "0x10", j2: 0 });
    const before = h.pushes();
    await run(5_000);
    expect(h.view().readingErrors).toBeGreaterThanOrEqual(5_000 / 20 - 1);
    expect(h.pushes() - before).toBeLessThanOrEqual(1 + 5_000 / ERROR_PUSH_MS);
    expect(h.pushes() - before).toBeGreaterThanOrEqual(5_000 / ERROR_PUSH_MS);
    // a good reading is pushed at once
    h.thing.answer = () => ({ j1: 0, j2: 0 });
    const failing = h.pushes();
    await run(20);
    expect(h.pushes()).toBe(failing + 1);
    h.follower.stop();
  });

  it("junk for longer than the horizon + one poll period is a monitor fault", async () => {
    const h = harness({ monitor: "stop" });
    h.follower.start();
    await run(100);
    h.thing.answer = () => ({ j1: 9, j2: 0 });
    await run(300);
    expect(h.view().monitorFault?.reason).toMatch(/last error: getJointPosition\.j1: 9 rad is beyond its limits/);
    expect(h.thing.stops).toEqual(["stop"]);
    h.follower.stop();
  });
});

describe("the monitor and the robot's lag", () => {
  /**
   * A robot jogging joint 1 toward the wall at `v` rad/s from 0; it halts at once on a stop. Its report is
   * `delay` ms late (and says so in a timestamp when `stamped`), then a first-order lag of `tau` s.
   */
  function lagging(h: Harness, o: { v: number; tau: number; delay: number; stamped: boolean }) {
    const robot = { p: 0, moving: true, history: [] as { t: number; r: number }[] };
    let r = 0;
    const clock = setInterval(() => {
      if (robot.moving) robot.p += o.v * 0.001;
      r += (robot.p - r) * (o.tau > 0 ? 1 - Math.exp(-0.001 / o.tau) : 1);
      robot.history.push({ t: Date.now(), r });
    }, 1);
    h.thing.answer = () => {
      const at = Date.now() - o.delay;
      const past = [...robot.history].reverse().find((s) => s.t <= at)?.r ?? 0;
      return { j1: past, j2: 0, ...(o.stamped ? { timestamp: new Date(at).toISOString() } : {}) };
    };
    h.thing.stopAnswer = async () => {
      robot.moving = false;
      return { stopped: true };
    };
    return { robot, done: () => clearInterval(clock) };
  }

  it.each([
    ["a first-order lag of tau = horizon", { v: 0.5, tau: 0.2, delay: 0, stamped: false }],
    ["a first-order lag of tau = horizon, fast", { v: 1.5, tau: 0.2, delay: 0, stamped: false }],
    ["a report 0.3 s late with its timestamp (past the horizon: measured)", { v: 0.5, tau: 0, delay: 300, stamped: true }],
  ])("%s: stopped before the wall", async (_what, o) => {
    const h = harness({ monitor: "stop", horizon: 0.2 });
    const { robot, done } = lagging(h, o);
    h.follower.start();
    await run(4_000);
    done();
    expect(h.events).toHaveLength(1);
    expect(h.events[0]!.stopped).toBe(true);
    expect(robot.moving).toBe(false);
    expect(robot.p).toBeLessThan(WALL);
    h.follower.stop();
  });

  it("a predicted contact whose stop hangs: the event says so at the stop's deadline, readings go on meanwhile", async () => {
    const h = harness({ monitor: "stop", horizon: 0.2, stopDeadlineMs: 1_000 });
    const { done } = lagging(h, { v: 0.5, tau: 0, delay: 0, stamped: false });
    h.thing.stopAnswer = () => new Promise(() => undefined);
    h.follower.start();
    for (let t = 0; t < 4_000 && h.thing.stops.length === 0; t += 10) await run(10);
    expect(h.thing.stops).toEqual(["stop"]);
    const reads = h.thing.reads;
    await run(999);
    expect(h.events).toHaveLength(0);
    expect(h.thing.reads).toBeGreaterThan(reads + 40);
    await run(1);
    expect(h.events).toHaveLength(1);
    expect(h.events[0]).toMatchObject({ stopped: false, error: "the stop to the physical robot failed: the stop (stop) to the physical robot: no answer within 1000 ms" });
    done();
    h.follower.stop();
  });

  it("the same late report without a timestamp is not measured: the horizon must cover it", async () => {
    const h = harness({ monitor: "stop", horizon: 0.2 });
    const { robot, done } = lagging(h, { v: 0.5, tau: 0, delay: 300, stamped: false });
    h.follower.start();
    await run(4_000);
    done();
    expect(robot.p).toBeGreaterThan(WALL);
    h.follower.stop();
  });

  it("extrapolates over horizon + age + verdict + one period, and the braking distance", async () => {
    const h = harness({ monitor: "warn", horizon: 0.2 });
    let q = 0;
    h.thing.answer = () => ({ j1: (q += 0.01), j2: 0 }); // 0.5 rad/s at 50 Hz
    h.follower.start();
    await run(200);
    const last = h.paths[h.paths.length - 1]!;
    // no time passes in a fake backend or round trip: age and verdict are 0
    const braking = 0.5 ** 2 / (2 * (VMAX / 0.25));
    expect(last.target[0]! - last.from[0]!).toBeCloseTo(0.5 * (0.2 + 0.02) + braking, 9);
    expect(last.target[1]).toBe(0);
    h.follower.stop();
  });
});
