/**
 * Follow (`serve --follow <TD URL>`): the twin reads the physical robot's joint state from that Thing
 * (consumed with node-wot) and shows it as its own observable property `physicalState` (joints, the
 * end-effector pose by the simulation's forward kinematics in the TD's frame, when it was read, its age).
 *
 * The state is read by polling `getJointPosition` at `rate` Hz. A consumed Thing's long-poll observation
 * only answers when the value changes, so a robot standing still and a connection that has died would look
 * the same; polling gives every value a time, and `age` says how old the last one is.
 *
 * While a move is relayed to the physical robot, each reading is compared with the simulated motion at the
 * same time since the command was sent (`Twin.relayed`; the simulated states interpolated, the last one
 * held): `divergence` (largest joint difference, end-effector distance) and its largest value during the
 * move; passing `divergenceBound` emits the `divergence` event once per relayed command.
 *
 * The safety monitor: every reading of a moving robot is checked against the scene (the twin's world: its
 * obstacles and other robots, and the robot itself) with the twin's clearance, over the straight joint-space
 * path to where its current velocity (from the last two readings, at most the joints' velocity limits) takes
 * it within `horizon` s, plus the time the monitor itself takes from a reading to its verdict (smoothed, at
 * most `horizon` again). While a relayed command runs and the robot keeps within the divergence bound of
 * its path, the prediction follows that path instead, as far as the current speed goes (`plannedAhead`):
 * a robot braking at its target or turning at a detour's corner is not heading where its velocity points. A contact on
 * that path emits `collisionImminent` with the bodies, and with `monitor: "stop"` stops the physical robot
 * through its Thing's `stop`; once per approach (until a reading is clear again). A robot already within the
 * clearance may move where it does not touch (out of it, as a jog after a stop does).
 *
 * When the physical robot moves without a command of the twin (a pendant jog, another client: the twin is
 * not busy with a move and the states differ by more than `FOLLOW_TOLERANCE`), the simulated robot is set to
 * the physical state, so the twin shows where the robot is, and `physicalState.followed` counts it. A move
 * of the twin (validated, simulated, relayed) is never interrupted by a reading.
 */
import type { BackendSupervisor } from "@robwot/sim-client";
import type { Vec3 } from "@robwot/core";
import { jointsFromPhysical, type RelayMap } from "./relay-map.js";
import type { CollisionImminentEvent, TrajectoryState, Twin } from "./twin.js";

/** rad or m: a larger difference between the physical and the simulated joints moves the simulated robot */
export const FOLLOW_TOLERANCE = 1e-4;
/** readings of the physical robot per second: the default and the range `--follow-rate` accepts */
export const FOLLOW_RATE = { default: 50, minimum: 1, maximum: 100 } as const;
/** rad or m: the default largest joint difference from the relayed motion before the `divergence` event */
export const DIVERGENCE_BOUND = 0.05;
/** s: how far ahead the safety monitor looks at the current joint velocity, by default */
export const MONITOR_HORIZON = 0.2;
/** rad/s (or m/s): a robot whose joints all move slower is standing still for the monitor */
const STILL = 1e-3;

/** The safety monitor's reaction to a predicted contact: stop the physical robot, only warn, or nothing. */
export type MonitorMode = "stop" | "warn" | "off";

/** The relayed motion's joints and end-effector position (virtual frame) `t` s after the command. */
function expectedAt(states: TrajectoryState[], t: number): TrajectoryState | null {
  if (states.length === 0) return null;
  const i = states.findIndex((s) => s.time >= t);
  if (i <= 0) return i === 0 ? states[0]! : states[states.length - 1]!;
  const a = states[i - 1]!;
  const b = states[i]!;
  const f = b.time > a.time ? (t - a.time) / (b.time - a.time) : 1;
  const mix = (x: number[], y: number[]): number[] => x.map((v, k) => v + f * ((y[k] ?? v) - v));
  return { time: t, q: mix(a.q, b.q), position: mix(a.position, b.position) as Vec3 };
}

/** rad: a relayed path ahead is checked as straight segments that leave none of its states further away */
const CORNER = 1e-3;

/** The largest joint difference (rad or m) between two joint vectors. */
function jointGap(a: readonly number[], b: readonly number[]): number {
  return Math.max(0, ...a.map((v, k) => Math.abs(v - (b[k] ?? v))));
}

/** The point of segment `a`-`b` nearest to `p` (Euclidean projection in joint space, clamped to the segment). */
function nearestOnSegment(p: readonly number[], a: readonly number[], b: readonly number[]): number[] {
  const ab = b.map((v, n) => v - (a[n] ?? v));
  const len2 = ab.reduce((sum, v) => sum + v * v, 0);
  const f = len2 > 0 ? Math.min(1, Math.max(0, p.reduce((sum, v, n) => sum + (v - (a[n] ?? v)) * (ab[n] ?? 0), 0) / len2)) : 0;
  return a.map((v, n) => v + (ab[n] ?? 0) * f);
}

/** The points of a polyline Douglas-Peucker keeps: every dropped point within `tolerance` (largest joint
 * difference) of the segment between the kept points around it; the first and the last kept. */
function simplify(points: number[][], tolerance: number): number[][] {
  if (points.length <= 2) return points;
  const a = points[0]!;
  const b = points[points.length - 1]!;
  let worst = 0;
  let at = 0;
  for (let k = 1; k < points.length - 1; k++) {
    const d = jointGap(points[k]!, nearestOnSegment(points[k]!, a, b));
    if (d > worst) [worst, at] = [d, k];
  }
  if (worst <= tolerance) return [a, b];
  return [...simplify(points.slice(0, at + 1), tolerance).slice(0, -1), ...simplify(points.slice(at), tolerance)];
}

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
  /** readings that moved the simulated robot to the physical one (it moved without a twin command) */
  followed: number;
  /** the safety monitor's reaction, and how many approaches it reported */
  monitor?: MonitorMode;
  collisionImminent?: number;
  /** when the last of them was read (ISO 8601) */
  lastFollowed?: string;
  /** while a move is relayed: how far the physical robot is from the simulated motion at the same time */
  divergence?: { joint: number; tcp: number };
  /** the largest divergence during the last relayed command, and the bound of the `divergence` event */
  maxDivergence?: { joint: number; tcp: number; bound: number };
  lastError?: string;
}

export class Follower {
  private state: { joints: Record<string, number>; position: { x: number; y: number; z: number }; orientation: PhysicalState["orientation"]; at: number } | null = null;
  private followed = 0;
  private lastFollowed = 0;
  private divergence: { joint: number; tcp: number } | null = null;
  private maxDivergence: { joint: number; tcp: number; sentAt: number; reported: boolean } | null = null;
  private lastError: string | undefined;
  private timer: NodeJS.Timeout | null = null;
  private stopped = false;
  private thing: Awaited<ReturnType<FollowWoT["consume"]>> | null = null;

  constructor(
    private readonly wot: FollowWoT,
    readonly url: string,
    private readonly twin: Twin,
    private readonly backend: BackendSupervisor,
    private readonly options: FollowOptions,
    private readonly onChange: () => void,
  ) {
    this.rate = options.rate;
    this.bound = options.divergenceBound ?? DIVERGENCE_BOUND;
  }

  private readonly rate: number;
  private readonly bound: number;
  /** the previous reading (joints, ms) for the joint velocity, and whether the current approach was reported */
  private previous: { q: number[]; at: number } | null = null;
  private warned = false;
  private imminent = 0;
  /** s from a reading to the monitor's verdict on it, smoothed: the robot moves on meanwhile */
  private lag = 0;
  /** the relayed motion (by when it was sent) and the segment of its path the robot was last nearest */
  private onPath: { sentAt: number; index: number } | null = null;

  start(): void {
    this.schedule(0);
  }

  stop(): void {
    this.stopped = true;
    if (this.timer) clearTimeout(this.timer);
  }

  view(): PhysicalState {
    const base = {
      following: true,
      source: this.url,
      followed: this.followed,
      ...(this.lastFollowed ? { lastFollowed: new Date(this.lastFollowed).toISOString() } : {}),
      ...(this.lastError ? { lastError: this.lastError } : {}),
      ...(this.divergence ? { divergence: this.divergence } : {}),
      ...(this.maxDivergence ? { maxDivergence: { joint: this.maxDivergence.joint, tcp: this.maxDivergence.tcp, bound: this.bound } } : {}),
      monitor: this.options.monitor ?? "stop",
      collisionImminent: this.imminent,
    };
    if (!this.state) return base;
    const { joints, position, orientation, at } = this.state;
    return { ...base, joints, position, ...(orientation ? { orientation } : {}), timestamp: new Date(at).toISOString(), age: (Date.now() - at) / 1000 };
  }

  private schedule(ms: number): void {
    if (this.stopped) return;
    this.timer = setTimeout(() => void this.read().finally(() => this.schedule(1000 / this.rate)), ms);
  }

  /** One reading: the joints, their pose, and the simulated robot set to them when it is not moving. */
  private async read(): Promise<void> {
    try {
      if (!this.thing) this.thing = await this.wot.consume(await this.wot.requestThingDescription(this.url));
      const map = this.options.map ?? null;
      const asked = Date.now();
      const out = await (await this.thing.readProperty(map ? map.jointState : "getJointPosition")).value();
      const at = Date.now();
      const twin = this.twin;
      const q = twin.jointsVector(map ? jointsFromPhysical(map, out) : ((out ?? {}) as Record<string, unknown>));
      if (!this.backend.isUp) throw new Error("simulation backend down: the physical pose is not computed");
      const fk = await this.backend.sim.fk(twin.robotId, q);
      const pose = twin.realPose([fk.position[0] ?? 0, fk.position[1] ?? 0, fk.position[2] ?? 0], {
        x: fk.orientation[0] ?? 0,
        y: fk.orientation[1] ?? 0,
        z: fk.orientation[2] ?? 0,
        w: fk.orientation[3] ?? 1,
      });
      this.state = { joints: twin.jointsRecord(q), position: pose.position, orientation: pose.orientation, at };
      this.lastError = undefined;
      this.compare(q, [fk.position[0] ?? 0, fk.position[1] ?? 0, fk.position[2] ?? 0], at);
      await this.monitor(q, at);
      const apart = jointGap(q, twin.q) > FOLLOW_TOLERANCE;
      // checked and sent in one turn of the event loop: a move accepted after this reading is sent after
      // it on the same ordered connection, so it plans from the physical state
      // a reading asked for before the twin's last move ended may show the robot on its way there (the
      // relayed command answered meanwhile): only a later one says it moved on its own
      if (apart && !twin.busy && twin.idleSince <= asked && twin.q.length === q.length) {
        const set = this.backend.sim.setJointPositions(twin.robotId, q);
        this.followed++;
        this.lastFollowed = at;
        await set;
        if (!twin.busy) twin.applyPose(q, fk);
      }
    } catch (err) {
      this.lastError = err instanceof Error ? err.message : String(err);
    }
    this.onChange();
  }

  /** The divergence of a reading taken at `at` from the relayed motion, if one is being relayed. */
  private compare(q: number[], position: Vec3, at: number): void {
    const relayed = this.twin.relayed;
    if (!relayed) {
      this.divergence = null;
      return;
    }
    const t = (at - relayed.sentAt) / 1000;
    const expected = expectedAt(relayed.states, t);
    if (!expected) return;
    const joint = jointGap(q, expected.q);
    const tcp = Math.hypot(...position.map((v, i) => v - (expected.position[i] ?? v)));
    this.divergence = { joint, tcp };
    if (this.maxDivergence?.sentAt !== relayed.sentAt) this.maxDivergence = { joint: 0, tcp: 0, sentAt: relayed.sentAt, reported: false };
    const max = this.maxDivergence;
    max.joint = Math.max(max.joint, joint);
    max.tcp = Math.max(max.tcp, tcp);
    if (joint > this.bound && !max.reported) {
      max.reported = true;
      this.twin.emit("divergence", { joint, tcp, time: t, bound: this.bound, joints: this.twin.jointsRecord(q), expected: this.twin.jointsRecord(expected.q) });
    }
  }

  /**
   * The joint-space polyline the relayed motion takes the robot along next, from where it is (`q`) as far as
   * `travel` (rad or m, largest joint), while a relayed command runs and the robot keeps within the
   * divergence bound of that motion's path; null otherwise. That path was checked with the clearance when
   * it was planned, and it is not where the current velocity points when the robot brakes at its target or
   * turns at a detour's corner: extrapolating would stop validated moves. The path, not the time, says where
   * the robot goes: one that runs late (latency, its own timing) is still on it.
   */
  private plannedAhead(q: number[], travel: number): number[][] | null {
    const relayed = this.twin.relayed;
    const states = relayed?.states.map((s) => s.q) ?? [];
    if (!relayed || states.length === 0) return null;
    // the robot only goes on along the path: the nearest segment from the one matched last
    if (this.onPath?.sentAt !== relayed.sentAt) this.onPath = { sentAt: relayed.sentAt, index: 0 };
    let best = { index: this.onPath.index, point: states[this.onPath.index]!, gap: jointGap(q, states[this.onPath.index]!) };
    for (let k = this.onPath.index; k + 1 < states.length; k++) {
      const point = nearestOnSegment(q, states[k]!, states[k + 1]!);
      const gap = jointGap(q, point);
      if (gap < best.gap) best = { index: k, point, gap };
    }
    if (best.gap > this.bound) return null;
    this.onPath.index = best.index;
    const ahead: number[][] = [best.point];
    let left = travel;
    for (let k = best.index + 1; k < states.length && left > 0; k++) {
      const a = ahead[ahead.length - 1]!;
      const b = states[k]!;
      const d = jointGap(a, b);
      ahead.push(d <= left ? b : a.map((v, n) => v + ((b[n] ?? v) - v) * (left / d)));
      left -= d;
    }
    return simplify([q, ...ahead], CORNER).slice(1);
  }

  /** The safety monitor on a reading `q` taken at `at` (see the module comment). */
  private async monitor(q: number[], at: number): Promise<void> {
    const mode = this.options.monitor ?? "stop";
    const previous = this.previous;
    this.previous = { q, at };
    if (mode === "off" || !previous || at <= previous.at) return;
    const dt = (at - previous.at) / 1000;
    // the limits of each joint of the vector, looked up once per reading
    const specs = this.twin.joints.map((name) => this.twin.model?.joints.find((x) => x.name === name));
    // no robot outruns its joints' velocity limits: two readings close in time (or a stand-in that jumps)
    // must not extrapolate beyond them
    const velocity = q.map((v, i) => {
      const raw = (v - (previous.q[i] ?? v)) / dt;
      const max = (specs[i]?.velocity ?? 0) > 0 ? specs[i]!.velocity : Infinity;
      return Math.max(-max, Math.min(max, raw));
    });
    if (velocity.every((v) => Math.abs(v) < STILL)) return;
    // the look-ahead starts where the robot is when the verdict comes, not where it was read: the horizon
    // grows by the measured reading-to-verdict time, at most doubled (a stalled backend must not turn
    // every motion into a predicted contact)
    const base = this.options.horizon ?? MONITOR_HORIZON;
    const horizon = base + Math.min(this.lag, base);
    const travel = Math.max(...velocity.map(Math.abs)) * horizon;
    const path = this.plannedAhead(q, travel) ?? [
      q.map((v, i) => Math.min(specs[i]?.upper ?? Infinity, Math.max(specs[i]?.lower ?? -Infinity, v + (velocity[i] ?? 0) * horizon))),
    ];
    // the segments one after the other, up to the first contact
    let from = q;
    let done = 0;
    let end = q;
    let hit: NonNullable<Awaited<ReturnType<BackendSupervisor["sim"]["checkPath"]>>["firstCollision"]> | null = null;
    for (const target of path) {
      const report = await this.backend.sim.checkPath({ robot: this.twin.robotId, from, target });
      if (!report.collisionFree && report.firstCollision) {
        [hit, end] = [report.firstCollision, target];
        break;
      }
      done += jointGap(from, target);
      from = target;
    }
    this.lag = 0.8 * this.lag + 0.2 * ((Date.now() - at) / 1000);
    if (!hit) {
      this.warned = false;
      return;
    }
    const travelled = done + jointGap(from, hit.positions);
    // already within the clearance (a robot the monitor stopped there): moving out of it is allowed, only
    // a motion into contact is stopped
    if (travelled === 0 && (await this.backend.sim.checkCollision(this.twin.robotId, end)).collisionFree) {
      this.warned = false;
      return;
    }
    if (this.warned) return;
    this.warned = true;
    this.imminent++;
    const event: CollisionImminentEvent = {
      contacts: hit.contacts.map((c) => ({ a: c.a, b: c.b })),
      // s at the current speed
      in: travel > 0 ? (travelled / travel) * horizon : 0,
      joints: this.twin.jointsRecord(q),
      stopped: false,
    };
    if (mode === "stop" && this.thing) {
      try {
        await this.thing.invokeAction(this.options.map ? this.options.map.stop : "stop");
        event.stopped = true;
      } catch (err) {
        event.error = `the stop to the physical robot failed: ${err instanceof Error ? err.message : String(err)}`;
      }
    }
    this.twin.emit("collisionImminent", event);
  }
}

