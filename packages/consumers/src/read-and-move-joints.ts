/**
 * Scenario 1: read the twin's state and move it in joint space.
 *
 * Consumes the TD with node-wot, reads getJointPosition / getCartesianPosition / motionStatus, picks
 * a joint target inside the limits the TD's schema declares (checking candidates with
 * validateJointPosition first, so a scene obstacle does not make the demo fail), invokes
 * moveToJointPosition and prints the result and the joint state read back afterwards.
 *
 *   node packages/consumers/dist/read-and-move-joints.js [TD URL] [--speed 0.5] [--fraction 0.3] [--json]
 */
import { numberOption, speedOption, parseArgs } from "./lib/args.js";
import { defaultTdUrl, invoke, openSession, read } from "./lib/connect.js";
import { fmt, fmtJoints, fmtXyz, printJsonSummary, table } from "./lib/format.js";
import { runScenario } from "./lib/run.js";
import { acceptedTargets, maxAbsDiff, spreadTargets } from "./lib/targets.js";
import { jointLimits } from "@robwot/core";
import type { CartesianPose, MotionStatus, MoveOutput } from "./lib/types.js";

const USAGE = "read-and-move-joints [TD URL] [--speed 0..1] [--fraction 0..0.9] [--json]";

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), { speed: "value", fraction: "value", json: "flag" });
  const url = args.positional[0] ?? defaultTdUrl();
  const speed = speedOption(args, 0.5);
  const fraction = numberOption(args, "fraction", 0.3, 0, 0.9);
  const session = await openSession();
  try {
    const twin = await session.connect(url);
    console.log(`Consumed "${twin.td.title ?? "?"}" from ${url}`);

    const joints = await read<Record<string, number>>(twin, "getJointPosition");
    const pose = await read<CartesianPose>(twin, "getCartesianPosition");
    const status = await read<MotionStatus>(twin, "motionStatus");
    console.log(`motionStatus: ${status.state}${status.lastError ? ` (last error ${status.lastError.code})` : ""}`);
    console.log(`end effector: ${fmtXyz(pose)} m`);

    const limits = jointLimits(twin.td);
    console.log(
      table(
        ["joint", "position", "lower", "upper", "unit"],
        limits.map((l) => [l.name, fmt(joints[l.name] ?? NaN), fmt(l.lower), fmt(l.upper), l.unit]),
      ),
    );

    // The first candidate the twin accepts that differs from where the robot already is.
    const [target] = await acceptedTargets(twin, spreadTargets(limits, fraction, 8), 1, joints, (t, reasons) =>
      console.log(`candidate ${fmtJoints(t, 2)} rejected: ${reasons.join("; ")}`),
    );
    if (target === undefined) throw new Error("no candidate joint target was accepted by validateJointPosition");

    console.log(`\nmoveToJointPosition speed=${speed}: ${fmtJoints(target)}`);
    const t0 = performance.now();
    const result = await invoke<MoveOutput>(twin, "moveToJointPosition", { joints: target, speed });
    const wall = (performance.now() - t0) / 1000;
    console.log(`result: status=${result.status} duration=${fmt(result.duration)} s (wall ${fmt(wall)} s)`);
    console.log(`reached end effector: ${fmtXyz(result.position)} m`);

    const after = await read<Record<string, number>>(twin, "getJointPosition");
    const error = maxAbsDiff(target, after);
    console.log(`joint state read back: ${fmtJoints(after)}`);
    console.log(`max |target - final| = ${error.toExponential(2)} rad`);
    if (result.status !== "reached") process.exitCode = 1;
    if (args.options.has("json")) printJsonSummary({ target, result, final: after, maxError: error, wall });
  } finally {
    await session.close();
  }
}

runScenario("read-and-move-joints", USAGE, main);
