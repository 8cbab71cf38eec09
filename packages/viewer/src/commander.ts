/**
 * Sends motion commands over HTTP (the TD's forms). Joint targets from the sliders are throttled:
 * one move in flight at a time, the newest target wins; a new target stops the running move first.
 */
import { ViewerError } from "./errors.js";
import { invokeAction, type TwinTd } from "./td.js";

export interface CommanderHooks {
  speed(): number;
  busy(active: boolean): void;
  result(action: string, result: unknown): void;
  error(action: string, err: unknown): void;
}

export class Commander {
  private inFlight = false;
  private pending: Record<string, number> | null = null;
  private stopping = false;

  constructor(
    private readonly td: TwinTd,
    private readonly hooks: CommanderHooks,
  ) {}

  moveJoints(joints: Record<string, number>): void {
    this.pending = joints;
    if (!this.inFlight) {
      this.drain();
      return;
    }
    if (!this.stopping) {
      this.stopping = true;
      // stop() reports its own failures through hooks.error and never rejects
      void this.stop().finally(() => (this.stopping = false));
    }
  }

  private drain(): void {
    const target = this.pending;
    this.pending = null;
    if (!target) {
      this.hooks.busy(false);
      return;
    }
    this.inFlight = true;
    this.hooks.busy(true);
    invokeAction(this.td, "moveToJointPosition", { joints: target, speed: this.hooks.speed() })
      .then(
        (r) => this.hooks.result("moveToJointPosition", r),
        (err: unknown) => this.hooks.error("moveToJointPosition", err),
      )
      .finally(() => {
        this.inFlight = false;
        this.drain();
      });
  }

  async moveCartesian(target: { x: number; y: number; z: number }, motion: "ptp" | "lin" = "ptp"): Promise<void> {
    try {
      const how = motion === "lin" ? { motion } : {};
      const r = await invokeAction(this.td, "moveToCartesianPosition", { ...target, speed: this.hooks.speed(), ...how });
      this.hooks.result("moveToCartesianPosition", r);
    } catch (err) {
      this.hooks.error("moveToCartesianPosition", err);
    }
  }

  async validateCartesian(target: { x: number; y: number; z: number }, motion: "ptp" | "lin" = "ptp"): Promise<unknown> {
    return invokeAction(this.td, "validateCartesianPosition", motion === "lin" ? { ...target, motion } : target);
  }

  async stop(): Promise<void> {
    try {
      const r = await invokeAction(this.td, "stop");
      this.hooks.result("stop", r);
    } catch (err) {
      this.hooks.error("stop", err instanceof ViewerError ? err : new ViewerError("E_STOP", String(err)));
    }
  }
}
