/**
 * A cell of the safety-monitor tests: an emulated robot (`robwot emulate`, which does not know the twin's
 * scene), moved to `start` before a twin watches it, and a twin that follows or relays to it, standing at
 * `start` too, with a /live stream of the twin. The first move is made before the twin watches: a long move
 * toward a folded pose is not what these files test, and the monitor's plain extrapolation of it (the
 * robot's deceleration unknown to it) may rightly stop it.
 */
import { expect } from "vitest";
import { startEmulator, startServient, type EmulatorOptions, type RunningEmulator, type RunningServient, type ServientOptions } from "../../packages/servient/src/index.js";
import { invoke, live, waitJoints, type LiveClient } from "../serve-helpers.js";

export interface EmulatedCell {
  robot: RunningEmulator;
  twin: RunningServient;
  /** the twin's Thing URL */
  base: string;
  /** the twin's /live stream */
  stream: LiveClient;
  stop(): Promise<void>;
}

export interface CellOptions {
  start: Record<string, number>;
  /** a fresh twin folder (one for the robot, one for the twin) */
  folder: () => Promise<string>;
  emulator?: Partial<EmulatorOptions>;
  /** the twin's link to the robot (`follow` or `relay` at its TD) and other options */
  twin: (robotTd: string) => Partial<ServientOptions>;
}

export async function startEmulatedCell(o: CellOptions): Promise<EmulatedCell> {
  const robot = await startEmulator({ folder: await o.folder(), port: 0, ...o.emulator });
  let twin: RunningServient | undefined;
  let stream: LiveClient | undefined;
  try {
    expect((await invoke(robot.tdUrl, "moveToJointPosition", { joints: o.start })).body.status).toBe("reached");
    twin = await startServient({ twins: [await o.folder()], port: 0, realtime: 0, ...o.twin(robot.tdUrl) });
    const base = twin.things[0]!.tdUrl;
    stream = await live(`${twin.liveUrl}?thing=${twin.things[0]!.slug}`);
    await waitJoints(base, o.start);
    const [t, s] = [twin, stream];
    return {
      robot,
      twin: t,
      base,
      stream: s,
      stop: async () => {
        s.close();
        await t.stop();
        await robot.stop();
      },
    };
  } catch (err) {
    stream?.close();
    await twin?.stop();
    await robot.stop();
    throw err;
  }
}
