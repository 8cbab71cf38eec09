/**
 * The emulated robot controller of `robwot emulate`: its true joints on a clock of `TICK_MS`, the motion
 * it runs (one at a time), and what it reports (a first-order lag of the true joints).
 *
 * A commanded motion starts after `latencyMs` and a stop meanwhile ends it. A line runs on a rest-to-rest
 * trapezoid of the straight joint-space line within the velocity limits x the move's speed and the
 * acceleration limits; a jog moves joints at given velocities for a time. A joint reaching its limit is a
 * protective stop: the joints are held at the limit and the status says so. The report follows the true
 * joints as a first-order filter of time constant `lag` s (at a constant velocity v it is v x lag behind).
 */
import { servientError } from "./errors.js";

/** ms between two steps of the emulated controller */
const TICK_MS = 5;

export interface ControllerLimits {
  names: string[];
  lower: number[];
  upper: number[];
  /** velocity limits (joint unit per s) */
  vmax: number[];
  /** acceleration limits (joint unit per s^2) */
  amax: number[];
}

export type MotionEnd = "reached" | "stopped";

export interface ControllerStatus {
  state: "idle" | "moving" | "stopped";
  lastError?: { code: string; message: string };
}

interface Motion {
  /** per tick: the next true joints, or null when the motion has ended */
  step(dt: number): number[] | null;
  /** where an ended motion leaves the joints (a line: its target), else where the last step left them */
  final?: number[];
  done: (end: MotionEnd) => void;
}

const sleep = (ms: number): Promise<void> => new Promise((r) => setTimeout(r, ms));

export class EmulatedController {
  private q: number[];
  private report: number[];
  private motion: Motion | null = null;
  private current: ControllerStatus = { state: "idle" };
  private readonly clock: NodeJS.Timeout;

  constructor(
    private readonly limits: ControllerLimits,
    start: number[],
    private readonly latencyMs: number,
    lag: number,
  ) {
    this.q = [...start];
    this.report = [...start];
    let last = performance.now();
    this.clock = setInterval(() => {
      const now = performance.now();
      const dt = (now - last) / 1000;
      last = now;
      this.tick(dt);
      const k = lag > 0 ? 1 - Math.exp(-dt / lag) : 1;
      this.report = this.report.map((r, i) => r + ((this.q[i] ?? r) - r) * k);
    }, TICK_MS);
  }

  /** the true joints */
  get joints(): number[] {
    return [...this.q];
  }

  /** the joints as reported (lagging the true ones) */
  get reported(): number[] {
    return [...this.report];
  }

  get status(): ControllerStatus {
    return this.current;
  }

  /** The straight joint-space line to `target` at `speed` x the velocity limits. */
  moveTo(target: number[], speed: number): Promise<MotionEnd> {
    return this.run(() => this.line(target, speed));
  }

  /** Each joint at its velocity (clamped to its limit) for `duration` s. */
  jog(velocities: number[], duration: number): Promise<MotionEnd> {
    const { vmax } = this.limits;
    const rates = velocities.map((r, k) => Math.max(-(vmax[k] ?? 1), Math.min(vmax[k] ?? 1, r)));
    let t = 0;
    return this.run(() => ({
      step: (dt) => {
        t += dt;
        return t >= duration ? null : this.q.map((x, k) => x + (rates[k] ?? 0) * dt);
      },
    }));
  }

  /** Ends the running motion (its command answers `stopped`); true when one was running. */
  stop(why?: { code: string; message: string }): boolean {
    const running = this.motion;
    this.motion = null;
    if (running) running.done("stopped");
    this.current = why ? { state: "stopped", lastError: why } : { state: running ? "stopped" : this.current.state };
    return running !== null;
  }

  /** Stops the motion and the clock. */
  close(): void {
    clearInterval(this.clock);
    this.stop();
  }

  /** Starts a motion after the latency, replacing nothing: a second command while moving is refused. */
  private async run(make: () => Omit<Motion, "done">): Promise<MotionEnd> {
    if (this.motion) throw servientError("E_BUSY", "the robot is moving: stop it first", { state: this.current.state });
    // until the latency has passed the robot holds still; a stop meanwhile ends the command
    const placeholder: Motion = { step: () => this.q, done: () => undefined };
    const result = new Promise<MotionEnd>((resolve) => (placeholder.done = resolve));
    this.motion = placeholder;
    this.current = { state: "moving" };
    await sleep(this.latencyMs);
    if (this.motion === placeholder) Object.assign(placeholder, make());
    return result;
  }

  /** A rest-to-rest trapezoid along the straight joint-space line to `target` within the limits x speed. */
  private line(target: number[], speed: number): Omit<Motion, "done"> {
    const { vmax, amax } = this.limits;
    const start = [...this.q];
    const delta = target.map((t, i) => t - (start[i] ?? 0));
    const moving = delta.map((d) => Math.abs(d) > 0);
    const vs = Math.min(...delta.map((d, i) => (moving[i] ? ((vmax[i] ?? 1) * speed) / Math.abs(d) : Infinity)));
    const as = Math.min(...delta.map((d, i) => (moving[i] ? (amax[i] ?? 1) / Math.abs(d) : Infinity)));
    const peak = Number.isFinite(vs) ? Math.min(vs, Math.sqrt(as)) : 0;
    const ramp = peak / as;
    const duration = Number.isFinite(vs) ? (peak < vs ? 2 * ramp : 1 / vs + vs / as) : 0;
    let t = 0;
    return {
      final: target,
      step: (dt) => {
        t += dt;
        if (t >= duration) return null;
        const rise = 0.5 * as * Math.min(t, ramp) ** 2;
        const cruise = peak * Math.min(Math.max(t - ramp, 0), Math.max(0, duration - 2 * ramp));
        const tail = Math.min(Math.max(t - (duration - ramp), 0), ramp);
        const s = Math.min(1, rise + cruise + peak * tail - 0.5 * as * tail * tail);
        return start.map((a, i) => a + s * (delta[i] ?? 0));
      },
    };
  }

  /** One step of the running motion; a joint beyond its limit is a protective stop there. */
  private tick(dt: number): void {
    const running = this.motion;
    if (!running) return;
    const { names, lower, upper } = this.limits;
    const next = running.step(dt);
    if (next === null) {
      if (running.final) this.q = [...running.final];
      this.motion = null;
      this.current = { state: "idle" };
      running.done("reached");
      return;
    }
    const beyond = next.findIndex((v, i) => v < (lower[i] ?? -Infinity) || v > (upper[i] ?? Infinity));
    if (beyond < 0) {
      this.q = next;
      return;
    }
    this.q = next.map((v, i) => Math.min(upper[i] ?? Infinity, Math.max(lower[i] ?? -Infinity, v)));
    this.stop({ code: "E_PROTECTIVE_STOP", message: `protective stop: joint ${names[beyond]} reached its limit` });
  }
}
