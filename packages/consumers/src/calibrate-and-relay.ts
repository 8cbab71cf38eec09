/**
 * Scenario 4: calibrate the virtual twin against a "physical" robot, then command it in the real frame.
 *
 * Setup: two twins. The "physical" twin stands in for the real robot (its world frame is the real
 * frame, e.g. a robot placed at another base position and yaw); the virtual twin is served with
 * `--relay <physical TD>` so every command it validates and performs is repeated on the physical one.
 *  1. Four joint configurations (inside the TD limits, accepted by validateJointPosition) are commanded
 *     on the virtual twin; the relay repeats each on the physical twin. For each we read the virtual
 *     end-effector position (virtual frame) and the physical one (real frame): one point pair.
 *  2. `calibrate` with the four pairs: x_real = s·R·x_virtual + t (Kabsch-Umeyama); prints s, R, t, RMS.
 *  3. A Cartesian target in the real frame (the centroid of the four real points, or a midpoint if that is
 *     rejected) is validated and sent to the virtual twin, which maps it into its own frame, moves, and
 *     relays the real-frame command; we read where the physical twin's end effector landed.
 *
 *   node packages/consumers/dist/calibrate-and-relay.js [VIRTUAL TD URL] [PHYSICAL TD URL]
 *        [--speed 1] [--fraction 0.35] [--no-scale] [--timeout 30] [--json]
 * Defaults: env ROBWOT_TD / ROBWOT_PHYSICAL_TD, else http://127.0.0.1:8080/<demo> and :8081/<demo>.
 */
import { numberOption, speedOption, parseArgs } from "./lib/args.js";
import { DEMO_SLUG, defaultTdUrl, invoke, openSession, read, type Twin } from "./lib/connect.js";
import { fmt, fmtXyz, printJsonSummary, table } from "./lib/format.js";
import { activeCalibration, axisAngle, centroid, invertCalibration, norm, spreadOffLine, sub, vec, xyz, type Vec3 } from "@robwot/core";
import { runScenario } from "./lib/run.js";
import { maxAbsDiff, spreadTargets, type Joints } from "./lib/targets.js";
import { jointLimits } from "@robwot/core";
import type { CalibrationResult, CalibrationState, CartesianPose, MotionStatus, RelayedMoveOutput, ValidationReport } from "./lib/types.js";

const USAGE = "calibrate-and-relay [VIRTUAL TD URL] [PHYSICAL TD URL] [--speed 0..1] [--fraction 0..0.9] [--no-scale] [--timeout S] [--json]";

const sleep = (ms: number): Promise<void> => new Promise((r) => setTimeout(r, ms));

/**
 * Wait until the physical twin has carried out the relayed command: not moving, and either its joints
 * equal `joints` (joint moves) or its motionStatus.lastResult differs from `before` (Cartesian moves).
 */
async function settle(physical: Twin, before: string, joints: Joints | undefined, timeoutS: number): Promise<{ pose: CartesianPose; joints: Joints; settled: boolean }> {
  const end = performance.now() + timeoutS * 1000;
  for (;;) {
    const status = await read<MotionStatus>(physical, "motionStatus");
    const now = await read<Joints>(physical, "getJointPosition");
    const done =
      status.state !== "moving" &&
      (joints !== undefined ? maxAbsDiff(joints, now) < 1e-3 : JSON.stringify(status.lastResult) !== before);
    if (done || performance.now() > end) {
      return { pose: await read<CartesianPose>(physical, "getCartesianPosition"), joints: now, settled: done };
    }
    await sleep(50);
  }
}

const lastResultOf = async (twin: Twin): Promise<string> => JSON.stringify((await read<MotionStatus>(twin, "motionStatus")).lastResult);

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), { speed: "value", fraction: "value", "no-scale": "flag", timeout: "value", json: "flag" });
  const virtualUrl = args.positional[0] ?? defaultTdUrl();
  const physicalUrl = args.positional[1] ?? defaultTdUrl("ROBWOT_PHYSICAL_TD", `http://127.0.0.1:8081/${DEMO_SLUG}`);
  const speed = speedOption(args, 1);
  const fraction = numberOption(args, "fraction", 0.35, 0.05, 0.9);
  const timeout = numberOption(args, "timeout", 30, 1, 600);
  const withScale = !args.options.has("no-scale");

  const session = await openSession();
  try {
    const virtual = await session.connect(virtualUrl);
    const physical = await session.connect(physicalUrl);
    console.log(`virtual twin:  "${virtual.td.title ?? "?"}" ${virtualUrl}`);
    console.log(`physical twin: "${physical.td.title ?? "?"}" ${physicalUrl}`);
    // A calibration from an earlier run maps the virtual twin's Cartesian outputs into the real
    // frame; undo it so the pairs hold true virtual-frame points.
    const previous = await read<CalibrationState>(virtual, "calibration");
    const active = activeCalibration(previous);
    if (active) console.log(`(an earlier calibration is active on the virtual twin; its outputs are un-mapped for the pairs)`);
    const virtualPoint = (p: CartesianPose): Vec3 => (active ? invertCalibration(active, vec(p)) : vec(p));

    // 1. Point pairs from four relayed joint moves.
    const pairs: { real: Vec3; virtual: Vec3; joints: Joints; relayError: number }[] = [];
    for (const target of spreadTargets(jointLimits(virtual.td), fraction, 16)) {
      if (pairs.length === 4) break;
      const verdict = await invoke<ValidationReport>(virtual, "validateJointPosition", { joints: target });
      if (!verdict.valid) {
        console.log(`skip a configuration the virtual twin rejects: ${verdict.reasons.join("; ")}`);
        continue;
      }
      const before = await lastResultOf(physical);
      const moved = await invoke<RelayedMoveOutput>(virtual, "moveToJointPosition", { joints: target, speed });
      if (moved.status !== "reached") throw new Error(`virtual twin move ended "${moved.status}"`);
      if (moved.relay === undefined) throw new Error(`the virtual twin did not relay the move: serve it with --relay ${physicalUrl}`);
      if (!moved.relay.ok) throw new Error(`relay to the physical twin failed: ${moved.relay.error ?? "?"}`);
      const phys = await settle(physical, before, target, timeout);
      if (!phys.settled) throw new Error(`the physical twin did not reach the relayed joint target within ${timeout} s (is the virtual twin served with --relay ${physicalUrl}?)`);
      const v = virtualPoint(await read<CartesianPose>(virtual, "getCartesianPosition"));
      pairs.push({ real: vec(phys.pose), virtual: v, joints: target, relayError: maxAbsDiff(target, phys.joints) });
    }
    if (pairs.length < 4) throw new Error(`only ${pairs.length} of 4 calibration configurations were accepted`);
    console.log(
      "\n" +
        table(
          ["pair", "virtual (m)", "real (m)", "relayed joints max |Δ| (rad)"],
          pairs.map((p, i) => [String(i + 1), fmtXyz(xyz(p.virtual)), fmtXyz(xyz(p.real)), p.relayError.toExponential(1)]),
        ),
    );
    console.log(`points spread ${fmt(spreadOffLine(pairs.map((p) => p.virtual)) * 100, 1)} cm off their longest line`);

    // 2. Calibrate.
    const cal = await invoke<CalibrationResult>(virtual, "calibrate", {
      pairs: pairs.map((p) => ({ real: xyz(p.real), virtual: xyz(p.virtual) })),
      withScale,
    });
    const { angle, axis } = axisAngle(cal.rotation);
    console.log(`\ncalibration (withScale=${withScale}): s=${fmt(cal.scale, 6)}  rotation ${fmt((angle * 180) / Math.PI, 3)} deg about (${axis.map((a) => fmt(a)).join(", ")})`);
    console.log(`  t=(${cal.translation.map((t) => fmt(t, 4)).join(", ")}) m  rms=${fmt(cal.rms * 1000, 4)} mm over ${cal.pairs} pairs`);

    // 3. A real-frame Cartesian command, relayed.
    const reals = pairs.map((p) => p.real);
    const candidates: Vec3[] = [centroid(reals), ...reals.map((r, i) => centroid([r, reals[(i + 1) % reals.length] as Vec3]))];
    let target: Vec3 | undefined;
    for (const c of candidates) {
      const verdict = await invoke<ValidationReport>(virtual, "validateCartesianPosition", xyz(c));
      if (verdict.valid) {
        target = c;
        break;
      }
      console.log(`real-frame target ${fmtXyz(xyz(c))} rejected: ${verdict.reasons.join("; ")}`);
    }
    if (target === undefined) throw new Error("no real-frame Cartesian target was accepted by validateCartesianPosition");
    const before = await lastResultOf(physical);
    console.log(`\nmoveToCartesianPosition (real frame) ${fmtXyz(xyz(target))}`);
    const result = await invoke<RelayedMoveOutput>(virtual, "moveToCartesianPosition", { ...xyz(target), speed });
    console.log(`virtual twin: ${result.status}, reports ${fmtXyz(result.position, 4)} (real frame)`);
    if (result.relay && !result.relay.ok) console.log(`relay to the physical twin FAILED: ${result.relay.error ?? "?"}`);
    const landed = await settle(physical, before, undefined, timeout);
    const error = norm(sub(vec(landed.pose), target));
    console.log(`physical twin landed at ${fmtXyz(landed.pose, 4)}: ${fmt(error * 1000, 4)} mm from the real-frame target${landed.settled ? "" : " (did not settle in time)"}`);
    if (!landed.settled || result.status !== "reached" || result.relay?.ok !== true) process.exitCode = 1;
    if (args.options.has("json")) {
      printJsonSummary({ pairs, calibration: cal, target: xyz(target), virtualResult: result, physical: landed.pose, errorM: error, settled: landed.settled });
    }
  } finally {
    await session.close();
  }
}

runScenario("calibrate-and-relay", USAGE, main);
