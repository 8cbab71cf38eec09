/**
 * The safety monitor of `serve --follow`: every reading of a moving physical robot is checked against the
 * scene (the twin's world: its obstacles and other robots, and the robot itself) with the twin's clearance,
 * over the joint-space path the robot may cover before a stop sent on the NEXT verdict would have brought
 * it to rest. From the reading's joints `q`, per joint at its velocity `v` (from the last two readings, at
 * most its velocity limit) and its deceleration `a`:
 *
 *   reach = |v| x (horizon + age + verdict + period) + v^2 / (2 a)
 *
 * - `age`: how old the reading was when it arrived, measured: the Thing's own timestamp where the reading
 *   has one, else the round trip of the read (the joints were read somewhere within it);
 * - `verdict`: the monitor's own reading-to-verdict time (smoothed, at most the horizon: a stalled backend
 *   must not turn every motion into a predicted contact);
 * - `period`: one poll period, until the next reading's verdict;
 * - `v^2 / (2 a)`: the braking distance, `a` the twin's acceleration limit of the joint (joint_limits.yaml),
 *   else its velocity limit reached in the contract's `Acceleration.x-accelerationTime`, as `robwot emulate`
 *   moves;
 * - `horizon` (`--horizon`): what the monitor cannot measure: the robot's reporting lag beyond a reading's
 *   round trip (a filtered report, a controller that samples late, without a timestamp) and the time its
 *   controller takes to act on a stop. A robot whose report lags a first-order filter of time constant tau
 *   is tau x its reported velocity behind, so a horizon >= tau covers it.
 *
 * While a relayed command runs and the robot keeps within the divergence bound of its path, the prediction
 * follows that path instead, as far as the largest joint's reach goes (`plannedAhead`): a robot braking at
 * its target or turning at a detour's corner is not heading where its velocity points. A contact on the path
 * emits `collisionImminent` with the bodies and, with mode `stop`, stops the physical robot through its
 * Thing's `stop` (the caller's `stop`, bounded by its deadline: never awaited by the verdicts that follow);
 * once per approach (until a reading is clear again). A robot already within the clearance may move where
 * it does not touch (out of it, as a jog after a stop does).
 */
import type { BackendSupervisor } from "@robwot/sim-client";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { jointGap, nearestOnSegment, simplify } from "./joint-path.js";
import type { CollisionImminentEvent, Twin } from "./twin.js";

/** The safety monitor's reaction to a predicted contact: stop the physical robot, only warn, or nothing. */
export type MonitorMode = "stop" | "warn" | "off";
/** s: the default `--horizon` (see the module comment for what it must cover) */
export const MONITOR_HORIZON = 0.2;
/** rad/s (or m/s): a robot whose joints all move slower is standing still for the monitor */
const STILL = 1e-3;
/** rad: a relayed path ahead is checked as straight segments that leave none of its states further away */
const CORNER = 1e-3;
const ACCELERATION_TIME = VALUE_SCHEMAS.Acceleration["x-accelerationTime"];

/** How a stop sent to the physical robot ended: answered, or why not (an error, no answer in time). */
export interface StopOutcome {
  ok: boolean;
  error?: string;
}

export interface MonitorOptions {
  mode: MonitorMode;
  /** s */
  horizon: number;
  /** s between two readings */
  period: number;
  /** rad or m: the divergence from a relayed path within which the prediction follows that path */
  bound: number;
  /** stops the physical robot; resolves (never rejects) once answered or past its deadline */
  stop: () => Promise<StopOutcome>;
}

type FirstCollision = NonNullable<Awaited<ReturnType<BackendSupervisor["sim"]["checkPath"]>>["firstCollision"]>;

export class SafetyMonitor {
  /** the previous reading (joints, when they were read, ms) for the joint velocity */
  private previous: { q: number[]; taken: number } | null = null;
  /** whether the current approach was reported */
  private warned = false;
  /** approaches reported */
  imminent = 0;
  /** s from a reading's arrival to the monitor's verdict on it, smoothed */
  private verdict = 0;
  /** the relayed motion (by when it was sent) and the segment of its path the robot was last nearest */
  private onPath: { sentAt: number; index: number } | null = null;

  constructor(
    private readonly twin: Twin,
    private readonly backend: BackendSupervisor,
    private readonly o: MonitorOptions,
  ) {}

  get mode(): MonitorMode {
    return this.o.mode;
  }

  /** Forgets the previous reading: a velocity across a gap in the readings is not the robot's. */
  reset(): void {
    this.previous = null;
  }

  /** s a reading of age `age` (s) is extrapolated over, before the braking distance. */
  lookahead(age: number): number {
    return this.o.horizon + age + Math.min(this.verdict, this.o.horizon) + this.o.period;
  }

  /**
   * The verdict on a reading `q` whose joints were read at `taken` (ms), `age` s old when it arrived at
   * `arrived` (ms). Resolves once the path is checked; a stop it sends is reported by the event later.
   */
  async check(q: number[], taken: number, age: number, arrived: number): Promise<void> {
    const previous = this.previous;
    this.previous = { q, taken };
    if (this.o.mode === "off" || !previous || taken <= previous.taken) return;
    const dt = (taken - previous.taken) / 1000;
    // the limits of each joint of the vector, looked up once per reading
    const specs = this.twin.joints.map((name) => this.twin.model?.joints.find((x) => x.name === name));
    const accelerations = this.twin.folder.manifest.robot.accelerations ?? {};
    // no robot outruns its joints' velocity limits: two readings close in time (or a stand-in that jumps)
    // must not extrapolate beyond them
    const velocity = q.map((v, i) => {
      const raw = (v - (previous.q[i] ?? v)) / dt;
      const max = (specs[i]?.velocity ?? 0) > 0 ? specs[i]!.velocity : Infinity;
      return Math.max(-max, Math.min(max, raw));
    });
    if (velocity.every((v) => Math.abs(v) < STILL)) return;
    const time = this.lookahead(age);
    const reach = velocity.map((v, i) => {
      const spec = specs[i];
      const a = (spec && accelerations[spec.name]) || (spec && spec.velocity > 0 ? spec.velocity / ACCELERATION_TIME : Infinity);
      return Math.abs(v) * time + (v * v) / (2 * a);
    });
    const travel = Math.max(...reach);
    const path = this.plannedAhead(q, travel) ?? [
      q.map((v, i) => Math.min(specs[i]?.upper ?? Infinity, Math.max(specs[i]?.lower ?? -Infinity, v + Math.sign(velocity[i] ?? 0) * (reach[i] ?? 0)))),
    ];
    // the segments one after the other, up to the first contact
    let from = q;
    let done = 0;
    let end = q;
    let hit: FirstCollision | null = null;
    for (const target of path) {
      const report = await this.backend.sim.checkPath({ robot: this.twin.robotId, from, target });
      if (!report.collisionFree && report.firstCollision) {
        [hit, end] = [report.firstCollision, target];
        break;
      }
      done += jointGap(from, target);
      from = target;
    }
    this.verdict = 0.8 * this.verdict + 0.2 * ((Date.now() - arrived) / 1000);
    if (!hit) {
      this.warned = false;
      return;
    }
    const travelled = done + jointGap(from, hit.positions);
    // already within the clearance (a robot the monitor stopped there): moving out of it is allowed, only
    // a motion into contact is stopped
    if (travelled === 0 && (await this.backend.sim.checkCollision({ robot: this.twin.robotId, positions: end })).collisionFree) {
      this.warned = false;
      return;
    }
    if (this.warned) return;
    this.warned = true;
    this.imminent++;
    const event: CollisionImminentEvent = {
      contacts: hit.contacts.map((c) => ({ a: c.a, b: c.b })),
      // s at the current speed
      in: travel > 0 ? (travelled / travel) * time : 0,
      joints: this.twin.jointsRecord(q),
      stopped: false,
    };
    if (this.o.mode !== "stop") {
      this.twin.emit("collisionImminent", event);
      return;
    }
    // the event says how the stop ended; the verdicts on the next readings do not wait for it
    void this.o.stop().then((outcome) => {
      event.stopped = outcome.ok;
      if (!outcome.ok) event.error = `the stop to the physical robot failed: ${outcome.error ?? "no answer"}`;
      this.twin.emit("collisionImminent", event);
    });
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
    const relayed = this.twin.motion.relayed;
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
    if (best.gap > this.o.bound) return null;
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
}
