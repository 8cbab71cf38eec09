/**
 * Follow (`serve --follow <TD URL>`): the twin reads the physical robot's joint state from that Thing
 * (consumed with node-wot) and shows it as its own observable property `physicalState` (joints, the
 * end-effector pose by the simulation's forward kinematics in the TD's frame, when it was read, its age).
 *
 * The state is read by polling `getJointPosition` at `rate` Hz. A consumed Thing's long-poll observation
 * only answers when the value changes, so a robot standing still and a connection that has died would look
 * the same; polling gives every value a time, and `age` says how old the last one is.
 *
 * Every request has a deadline of the follower's own, whatever the HTTP client does: the TD fetch and
 * consume `connectDeadlineMs`, a reading the horizon (older, it is no use to the monitor; `FOLLOW_DEADLINE_MS`
 * with the monitor off), the monitor's stop `stopDeadlineMs`. A request past its deadline is an error in
 * `lastError` and polling goes on; at most one request of the follower is in flight: while the previous one
 * is still pending (its deadline passed, its answer not yet come), a poll is skipped and counted
 * (`skippedPolls`), never sent beside it.
 *
 * A reading is parsed strictly (`reading.ts`, `relay-map.ts`): the exact joint set, finite numbers, within
 * the joints' limits up to `LIMIT_TOLERANCE` (then followed clamped, `clamped` says what was read); anything
 * else is an error naming the field, never a pose. While readings fail, `physicalState` is pushed to its
 * observers (/live, SSE, long poll) on the first failure and then at most every `ERROR_PUSH_MS` (a read of
 * the property shows the latest); a good reading, a fault and its end are pushed at once.
 *
 * Blind: with the monitor on, a robot without a usable reading for the horizon plus one poll period (the
 * time the last verdict covered; from start, the TD fetch's deadline is allowed before it) is a
 * monitor fault: `physicalState.monitorFault` (since when, why, the stop), `motionStatus.lastError`
 * (`E_MONITOR_BLIND`), the `physical` change, a process warning, and with mode `stop` one stop per blind
 * episode. The fault ends with the next usable reading.
 *
 * While a move is relayed, each reading is compared with the simulated motion (`divergence.ts`), and every
 * reading is checked by the safety monitor (`monitor.ts`).
 *
 * When the physical robot moves without a command of the twin (a pendant jog, another client: the twin is
 * not busy with a move and the states differ by more than `FOLLOW_TOLERANCE`), the simulated robot is set to
 * the physical state, so the twin shows where the robot is, and `physicalState.followed` counts it. A move
 * of the twin (validated, simulated, relayed) is never interrupted by a reading.
 */
import type { BackendSupervisor } from "@robwot/sim-client";
import type { Vec3 } from "@robwot/core";
import { DeadlineError, withDeadline } from "./deadline.js";
import { Divergence } from "./divergence.js";
import { jointGap } from "./joint-path.js";
import { MONITOR_HORIZON, SafetyMonitor, type MonitorMode } from "./monitor.js";
import { BlindWatch, BoundedStop, type MonitorFault } from "./monitor-fault.js";
import { clip, parseJointRecord, ReadingError, withinLimits } from "./reading.js";
import { jointsFromPhysical, type RelayMap } from "./relay-map.js";
import type { Twin } from "./twin.js";

export { MONITOR_HORIZON, type MonitorMode } from "./monitor.js";
export { MONITOR_BLIND, type MonitorFault } from "./monitor-fault.js";

/** rad or m: a larger difference between the physical and the simulated joints moves the simulated robot */
export const FOLLOW_TOLERANCE = 1e-4;
/** readings of the physical robot per second: the default and the range `--follow-rate` accepts */
export const FOLLOW_RATE = { default: 50, minimum: 1, maximum: 100 } as const;
/** rad or m: the default largest joint difference from the relayed motion before the `divergence` event */
export const DIVERGENCE_BOUND = 0.05;
/** ms: the TD fetch and consume of the physical Thing, by default */
export const CONNECT_DEADLINE_MS = 2_000;
/** ms: a reading with the monitor off, by default (with it on: the horizon) */
export const FOLLOW_DEADLINE_MS = 2_000;
/** ms: the monitor's stop to the physical robot, by default */
export const MONITOR_STOP_DEADLINE_MS = 1_000;
/** ms: while readings fail, the least time between two pushes of physicalState */
export const ERROR_PUSH_MS = 1_000;

/** The part of node-wot's WoT API the follower needs. */
export interface FollowWoT {
  requestThingDescription(url: string): Promise<unknown>;
  consume(td: unknown): Promise<{
    readProperty(name: string): Promise<{ value(): Promise<unknown> }>;
    invokeAction(name: string, input?: unknown): Promise<unknown>;
  }>;
}

export interface FollowOptions {
  /** readings per second */
  rate: number;
  /** the physical Thing's own names (`--relay-map`) */
  map?: RelayMap | null;
  divergenceBound?: number;
  monitor?: MonitorMode;
  horizon?: number;
  connectDeadlineMs?: number;
  readDeadlineMs?: number;
  stopDeadlineMs?: number;
}

/** `physicalState`: what the twin last read from the physical robot. */
export interface PhysicalState {
  following: boolean;
  source?: string;
  joints?: Record<string, number>;
  position?: { x: number; y: number; z: number };
  orientation?: { x: number; y: number; z: number; w: number };
  /** when the joints were read (ISO 8601) */
  timestamp?: string;
  /** s since then */
  age?: number;
  /** joints read past their limit (within the tolerance) and what was read; `joints` shows them clamped */
  clamped?: Record<string, number>;
  /** readings that moved the simulated robot to the physical one (it moved without a twin command) */
  followed: number;
  /** when the last of them was read (ISO 8601) */
  lastFollowed?: string;
  /** the safety monitor's reaction, and how many approaches it reported */
  monitor?: MonitorMode;
  collisionImminent?: number;
  /** the monitor cannot see the robot (present while it lasts), and how many such faults there were */
  monitorFault?: MonitorFault;
  monitorFaults?: number;
  /** polls skipped because the previous request was still unanswered; readings that failed */
  skippedPolls?: number;
  readingErrors?: number;
  /** while a move is relayed: how far the physical robot is from the simulated motion at the same time */
  divergence?: { joint: number; tcp: number };
  /** the largest divergence during the last relayed command, and the bound of the `divergence` event */
  maxDivergence?: { joint: number; tcp: number; bound: number };
  lastError?: string;
}

type Consumed = Awaited<ReturnType<FollowWoT["consume"]>>;

/** A usable reading: the joints (twin order, within limits), when they were read and how old they were (s). */
interface Observation {
  q: number[];
  clamped: Record<string, number>;
  /** ms: the request was sent */
  asked: number;
  /** ms: the Thing's timestamp, else when the request was sent */
  taken: number;
  /** ms: the answer came */
  arrived: number;
  age: number;
}

const message = (err: unknown): string => clip(err instanceof Error ? err.message : String(err));
const iso = (ms: number): string => new Date(ms).toISOString();

export class Follower {
  private state: { joints: Record<string, number>; clamped: Record<string, number>; position: { x: number; y: number; z: number }; orientation: PhysicalState["orientation"]; at: number } | null = null;
  private followed = 0;
  private lastFollowed = 0;
  private readonly divergence: Divergence;
  private lastError: string | undefined;
  private timer: NodeJS.Timeout | null = null;
  private stopped = false;
  private thing: Consumed | null = null;
  /** the follower's one request in flight (TD or reading) and when it was sent (ms) */
  private pending: { what: string; since: number } | null = null;
  private skipped = 0;
  private errors = 0;
  /** ms: the follower started, and the last usable reading arrived (null before the first) */
  private startedAt = 0;
  private lastGood: number | null = null;
  /** fires when the robot has been unseen for `blindAfterMs`: re-armed by every usable reading */
  private blindTimer: NodeJS.Timeout | null = null;
  /** whether the last reading failed, and when a failure was last pushed (ms) */
  private failing = false;
  private lastErrorPush = -Infinity;
  /** the reading being processed (FK, monitor, follow) and the newest one waiting for it */
  private processing = false;
  private queued: Observation | null = null;
  private readonly monitor: SafetyMonitor;
  private readonly blind: BlindWatch;
  private readonly period: number;
  private readonly horizon: number;
  private readonly deadlines: { connect: number; read: number; stop: number };

  constructor(
    private readonly wot: FollowWoT,
    readonly url: string,
    private readonly twin: Twin,
    private readonly backend: BackendSupervisor,
    private readonly options: FollowOptions,
    private readonly onChange: () => void,
  ) {
    this.period = 1 / options.rate;
    this.horizon = options.horizon ?? MONITOR_HORIZON;
    const bound = options.divergenceBound ?? DIVERGENCE_BOUND;
    this.divergence = new Divergence(twin, bound);
    const mode = options.monitor ?? "stop";
    this.deadlines = {
      connect: options.connectDeadlineMs ?? CONNECT_DEADLINE_MS,
      read: options.readDeadlineMs ?? (mode === "off" ? FOLLOW_DEADLINE_MS : this.horizon * 1000),
      stop: options.stopDeadlineMs ?? MONITOR_STOP_DEADLINE_MS,
    };
    const name = options.map?.stop ?? "stop";
    const stop = new BoundedStop(
      () => this.thing?.invokeAction(name) ?? `the physical Thing's TD (${url}) was never read: no stop could be sent`,
      this.deadlines.stop,
      `the stop (${name}) to the physical robot`,
    );
    this.monitor = new SafetyMonitor(twin, backend, { mode, horizon: this.horizon, period: this.period, bound, stop: () => stop.stop() });
    this.blind = new BlindWatch(twin, mode, () => stop.stop(), onChange);
  }

  /** ms without a usable reading after which the monitor is blind: the horizon plus one poll period */
  get blindAfterMs(): number {
    return (this.horizon + this.period) * 1000;
  }

  start(): void {
    this.startedAt = Date.now();
    // the first reading is due once the TD is fetched: a twin that never saw its robot is blind too
    this.arm(this.deadlines.connect + this.blindAfterMs);
    this.tick();
  }

  stop(): void {
    this.stopped = true;
    if (this.timer) clearTimeout(this.timer);
    if (this.blindTimer) clearTimeout(this.blindTimer);
  }

  view(): PhysicalState {
    const fault = this.blind.view();
    const base = {
      following: true,
      source: this.url,
      followed: this.followed,
      ...(this.lastFollowed ? { lastFollowed: iso(this.lastFollowed) } : {}),
      ...(this.lastError ? { lastError: this.lastError } : {}),
      ...this.divergence.view(),
      monitor: this.monitor.mode,
      collisionImminent: this.monitor.imminent,
      ...(fault ? { monitorFault: fault } : {}),
      monitorFaults: this.blind.count,
      skippedPolls: this.skipped,
      readingErrors: this.errors,
    };
    if (!this.state) return base;
    const { joints, clamped, position, orientation, at } = this.state;
    return {
      ...base,
      joints,
      ...(Object.keys(clamped).length > 0 ? { clamped } : {}),
      position,
      ...(orientation ? { orientation } : {}),
      timestamp: iso(at),
      age: (Date.now() - at) / 1000,
    };
  }

  /** One poll: a request unless the previous one is still unanswered. */
  private tick(): void {
    if (this.stopped) return;
    this.timer = setTimeout(() => this.tick(), this.period * 1000);
    this.blind.hold();
    if (this.pending) {
      this.skipped++;
      return;
    }
    const asked = Date.now();
    const thing = this.thing;
    const property = this.options.map?.jointState ?? "getJointPosition";
    const what = thing ? `reading ${property}` : `the TD at ${this.url}`;
    const raw = (async (): Promise<unknown> => (thing ? (await thing.readProperty(property)).value() : this.wot.consume(await this.wot.requestThingDescription(this.url))))();
    const pending = { what, since: asked };
    this.pending = pending;
    const settled = (): void => {
      if (this.pending === pending) this.pending = null;
    };
    void raw.then(settled, settled);
    void withDeadline(raw, thing ? this.deadlines.read : this.deadlines.connect, what).then(
      (value) => {
        if (this.stopped) return;
        if (thing) this.accept(value, asked);
        else this.thing = value as Consumed;
      },
      (err: unknown) => {
        // a TD that came after its deadline is still the Thing's
        if (!thing && err instanceof DeadlineError) void raw.then((t) => (this.thing ??= t as Consumed), () => undefined);
        if (!this.stopped) this.fail(err);
      },
    );
  }

  /** A reading answered: parsed strictly; a usable one ends blindness and goes to processing. */
  private accept(value: unknown, asked: number): void {
    const arrived = Date.now();
    let reading: Observation;
    try {
      const map = this.options.map ?? null;
      const parsed = map ? { record: jointsFromPhysical(map, value) } : parseJointRecord(value, this.twin.joints);
      const property = map?.jointState ?? "getJointPosition";
      const ranges = this.twin.joints.map((name) => this.twin.model?.joints.find((j) => j.name === name));
      const vector = this.twin.joints.map((j) => {
        const v = parsed.record[j];
        if (v === undefined) throw new ReadingError(property, `no value for the twin's joint ${j}`);
        return v;
      });
      const { q, clamped } = withinLimits(vector, ranges, property);
      const taken = parsed.timestamp ?? asked;
      reading = { q, clamped, asked, taken, arrived, age: Math.max(arrived - asked, arrived - taken) / 1000 };
    } catch (err) {
      this.fail(err);
      return;
    }
    this.lastGood = arrived;
    this.arm(this.blindAfterMs);
    if (this.blind.active) {
      this.monitor.reset();
      this.failing = false;
      this.blind.end();
    }
    if (this.processing) this.queued = reading;
    else void this.process(reading);
  }

  private fail(err: unknown): void {
    this.errors++;
    this.lastError = message(err);
    this.changed(false);
  }

  /** Pushes the state: at once after a good reading, at most every `ERROR_PUSH_MS` while readings fail. */
  private changed(good: boolean): void {
    const now = Date.now();
    if (good || !this.failing || now - this.lastErrorPush >= ERROR_PUSH_MS) {
      if (!good) this.lastErrorPush = now;
      this.onChange();
    }
    this.failing = !good;
  }

  /** The reading's pose, divergence, the monitor's verdict, and the simulated robot set to it when it is not moving. */
  private async process(r: Observation): Promise<void> {
    this.processing = true;
    const twin = this.twin;
    let good = false;
    try {
      if (!this.backend.isUp) throw new Error("simulation backend down: the physical pose is not computed");
      const fk = await this.backend.sim.fk({ robot: twin.robotId, positions: r.q });
      const position: Vec3 = [fk.position[0] ?? 0, fk.position[1] ?? 0, fk.position[2] ?? 0];
      const pose = twin.realPose(position, { x: fk.orientation[0] ?? 0, y: fk.orientation[1] ?? 0, z: fk.orientation[2] ?? 0, w: fk.orientation[3] ?? 1 });
      this.state = { joints: twin.jointsRecord(r.q), clamped: r.clamped, position: pose.position, orientation: pose.orientation, at: r.arrived };
      this.lastError = undefined;
      this.divergence.compare(r.q, position, r.arrived);
      await this.monitor.check(r.q, r.taken, r.age, r.arrived);
      const apart = jointGap(r.q, twin.q) > FOLLOW_TOLERANCE;
      // checked and sent in one turn of the event loop: a move accepted after this reading is sent after
      // it on the same ordered connection, so it plans from the physical state
      // a reading asked for before the twin's last move ended may show the robot on its way there (the
      // relayed command answered meanwhile): only a later one says it moved on its own
      if (apart && !twin.motion.busy && twin.motion.idleSince <= r.asked && twin.q.length === r.q.length) {
        const set = this.backend.sim.setJointPositions({ robot: twin.robotId, positions: r.q });
        this.followed++;
        this.lastFollowed = r.arrived;
        await set;
        if (!twin.motion.busy) twin.applyPose(r.q, fk);
      }
      good = true;
    } catch (err) {
      this.lastError = message(err);
    } finally {
      this.processing = false;
    }
    this.changed(good);
    const next = this.queued;
    this.queued = null;
    if (next && !this.stopped) void this.process(next);
  }

  /** With the monitor on: the fault is declared `ms` from now unless a usable reading comes first. */
  private arm(ms: number): void {
    if (this.monitor.mode === "off" || this.stopped) return;
    if (this.blindTimer) clearTimeout(this.blindTimer);
    this.blindTimer = setTimeout(() => this.declareBlind(), ms);
  }

  private declareBlind(): void {
    if (this.stopped || this.blind.active) return;
    const now = Date.now();
    // the last reading the twin shows (one accepted while its pose is still being computed is not seen yet)
    const since = this.state?.at ?? this.lastGood ?? this.startedAt;
    const unanswered = this.pending ? `; ${this.pending.what} sent ${now - this.pending.since} ms ago is unanswered` : "";
    const last = this.lastError ? `; last error: ${this.lastError}` : "";
    this.monitor.reset();
    this.blind.declare(now, since, `the safety monitor is blind: no usable reading of the physical robot for ${now - since} ms (the horizon ${this.horizon} s + one poll period ${this.period} s)${unanswered}${last}`);
  }
}
