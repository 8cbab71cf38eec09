/**
 * `gripClose` / `gripOpen` (`generate --gripper`): the gripper closed or opened as the twin's one motion
 * (409 `E_BUSY` while it moves, a stop ends it): `moving` for the gripper's time (scaled by `--realtime`,
 * none at 0), then the backend's `gripper.close` / `gripper.open` (what it catches, holds and lets go:
 * `sim/gripper.py`), the twin's joints (its fingers) and the world's objects updated from its answer.
 */
import type { ActionDeps } from "./actions.js";
import type { MoveWatch } from "./moves.js";

export interface GripOutput {
  /** `stopped`: a stop came before the gripper closed or opened; nothing changed */
  status: "done" | "stopped";
  state: "open" | "closed";
  holding: string | null;
  /** gripOpen: the object let go, where it came to rest (null when none was held) */
  released?: unknown;
}

export async function grip(d: ActionDeps, close: boolean, watch?: MoveWatch): Promise<GripOutput> {
  const { twin, backend } = d;
  return d.mover.exclusive(async (cancelled) => {
    const before = twin.gripper ?? { state: "open" as const, holding: null, time: 0 };
    const settled = { state: before.state === "moving" ? "open" as const : before.state, holding: before.holding };
    twin.setGripper({ state: "moving" });
    try {
      const fastest = !d.realtime; // as fast as possible: the gripper takes no time
      if (!fastest) await waitUnless(cancelled, secondsToMs(before.time) / d.realtime);
      if (cancelled()) {
        twin.setGripper(settled);
        return { status: "stopped", ...settled };
      }
      const robot = { robot: twin.robotId };
      const r = close ? await backend.sim.closeGripper(robot) : await backend.sim.openGripper(robot);
      twin.applyPose(r.positions, await backend.sim.fk({ robot: twin.robotId, positions: r.positions }));
      await d.world.syncObjects(backend);
      twin.setGripper({ state: r.state, holding: r.holding });
      return { status: "done", state: r.state, holding: r.holding, ...(close ? {} : { released: r.released ?? null }) };
    } catch (err) {
      twin.setGripper(settled);
      throw err;
    }
  }, watch);
}

const secondsToMs = (s: number): number => s * 1000;

/** After a program whose grip or release steps ran (or some of them): the gripper's state and the world's
 *  objects as the backend holds them now. Never throws: a backend that is down restores both anyway. */
export async function gripChanged(d: ActionDeps): Promise<void> {
  try {
    const g = await d.backend.sim.gripperState({ robot: d.twin.robotId });
    await d.world.syncObjects(d.backend);
    d.twin.setGripper({ state: g.state, holding: g.holding });
  } catch {
    /* the backend restarted or went down: its restore reopens the gripper and replays the objects */
  }
}

/** Waits `ms`, checking `cancelled` every 20 ms: a stop ends the wait at once. */
async function waitUnless(cancelled: () => boolean, ms: number): Promise<void> {
  const end = Date.now() + ms;
  while (!cancelled() && Date.now() < end) {
    await new Promise((resolve) => setTimeout(resolve, Math.min(20, end - Date.now())));
  }
}
