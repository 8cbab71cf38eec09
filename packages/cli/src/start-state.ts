/**
 * What generate checks of the twin's start before it samples: the start pose (`--home`, over the SRDF's
 * `home` state, else where the robot loads) against the loaded robot's joints and limits and for
 * contacts, and the scene's other robots that can touch this one. Each finding is said as soon as it is
 * known (`Warnings`), not after the samples.
 */
import { reachOverlaps, startCollision } from "@robwot/core";
import type { RobotModel, SimClient, WorkspaceSummary, WorldList } from "@robwot/sim-client";
import { CliError } from "./errors.js";
import type { ProgressSink } from "./progress.js";
import type { RosInput } from "./ros-input.js";

export type Home = NonNullable<RosInput["home"]>;

/** Slack (rad or m) of the limits check: a limit printed and given back reads equal. */
const LIMIT_SLACK = 1e-9;

/** The warnings of one generate, each printed once as soon as it is known (`robwot: warning: ...`), all
 * kept for the result (`--json`). */
export class Warnings {
  private readonly said: string[] = [];
  constructor(private readonly progress: ProgressSink) {}

  say(found: readonly string[]): void {
    for (const w of found) {
      if (this.said.includes(w)) continue;
      this.said.push(w);
      this.progress.info(`warning: ${w}`);
    }
  }

  get all(): string[] {
    return [...this.said];
  }
}

/**
 * `--home` against the loaded robot: every name a controllable joint, every value within its limits
 * (else a CliError naming it, with the joints there are); the joints it does not name stay where the
 * robot loads (`current`). Without `--home`: the SRDF's home, if any.
 */
export function resolveHome(model: RobotModel, given: Record<string, number> | undefined, srdf: Home | undefined, current: readonly number[]): Home | undefined {
  if (given === undefined) return srdf;
  for (const [name, value] of Object.entries(given)) {
    const joint = model.joints.find((j) => j.name === name);
    if (joint === undefined || !model.controllable.includes(name)) {
      const why = joint === undefined ? "not a joint of the robot" : model.couplings.some((c) => c.follower === name) ? "a joint that follows others (its coupling sets it)" : `a ${joint.type} joint`;
      throw new CliError(`--home ${name}=${value}: ${name} is ${why}; the robot's controllable joints: ${model.controllable.join(", ")}`);
    }
    if (value < joint.lower - LIMIT_SLACK || value > joint.upper + LIMIT_SLACK) {
      throw new CliError(`--home ${name}=${value} is outside the joint's limits [${joint.lower}, ${joint.upper}]`);
    }
  }
  return { joints: Object.fromEntries(model.controllable.map((n, i) => [n, given[n] ?? current[i] ?? 0])), from: "--home" };
}

/**
 * The start pose resolved (`resolveHome`) and checked with `robot.checkCollision`: a pose in contact is
 * warned about, naming the bodies. The pose is the one serve starts the twin in: a home's joints (serve
 * puts a joint a home does not name at 0), else where the robot loads.
 */
export async function checkStart(sim: SimClient, model: RobotModel, given: Record<string, number> | undefined, srdf: Home | undefined, warnings: Warnings): Promise<Home | undefined> {
  const { positions } = await sim.getJointPositions({ robot: model.id });
  const home = resolveHome(model, given, srdf, positions);
  const q = home === undefined ? positions : model.controllable.map((j) => home.joints[j] ?? 0);
  const report = await sim.checkCollision({ robot: model.id, positions: q });
  const said = startCollision(`the start pose (${home?.from ?? "the robot as loaded"})`, report.contacts);
  if (said !== undefined) warnings.say([said]);
  return home;
}

/** Robots of the scene that can touch this one: by their bases alone before the workspace is sampled,
 * by this robot's reach box (`summary.reachBounds`) after. */
export function overlapWarnings(model: RobotModel, others: WorldList["robots"], summary?: WorkspaceSummary): string[] {
  const base = (p: readonly number[]): [number, number, number] => [p[0] ?? 0, p[1] ?? 0, p[2] ?? 0];
  return reachOverlaps([
    { name: `this robot (${model.id})`, base: base(model.basePosition ?? [0, 0, 0]), ...(summary?.reachBounds ? { reach: summary.reachBounds } : {}) },
    ...others.map((r) => ({ name: `the scene's robot ${r.id}`, base: base(r.basePosition) })),
  ]);
}
