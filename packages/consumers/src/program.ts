/**
 * Scenario 6: a pick-and-place program (README "Programs"), validated as a whole, then run.
 *
 * A pick station and a place station either side of the workspace (from the TD's Cartesian bounds, as the
 * pick-and-place scenario places them) and the program a UR or KUKA programmer writes between them, from
 * where the robot stands (its joints are "home"): PTP above the pick, LIN down, LIN up, PTP above the place,
 * LIN down, LIN up, PTP home, the tool pointing down (the end-effector frame's z axis along -z, as a
 * flange's is when it points at a table); the LINs keep that orientation. `validateProgram` checks it step
 * by step; when a step is refused, the scenario prints the step and why and tries the next layout: the
 * stations on the other axis, then without a fixed orientation (the PTP's IK chooses one, the LINs keep
 * it), then closer to the middle. The accepted program runs with `runProgram`: the scenario prints each
 * step's planned duration, the cycle time, and the simulated duration and wall time of the run; the
 * simulated duration must equal the cycle time. The trajectory validateProgram answers is summed up in one
 * line (samples, rate, time span); `--verbose` prints its samples (and keeps it in the `--json` summary).
 *
 *   node packages/consumers/dist/program.js [TD URL] [--lift 0.08] [--tcp-speed 0.2] [--verbose] [--json]
 */
import { numberOption, parseArgs } from "./lib/args.js";
import { defaultTdUrl, invoke, openSession, read } from "./lib/connect.js";
import { fmt, fmtXyz, printJsonSummary, table } from "./lib/format.js";
import { runScenario } from "./lib/run.js";
import { tableStations } from "./lib/targets.js";
import { cartesianBounds, xyz, type Vec3 } from "@robwot/core";

const USAGE = "program [TD URL] [--lift 0.01..0.3] [--tcp-speed 0.01..1] [--verbose] [--json]";
/** the end-effector frame's z axis pointing down (a half turn about x), quaternion {x, y, z, w} */
const DOWN = { x: 1, y: 0, z: 0, w: 0 };

interface ProgramReport {
  valid: boolean;
  firstFailingStep?: number;
  cycleTime: number;
  steps: { step: number; ok: boolean; reasons: string[]; duration: number; planned?: string }[];
  trajectory?: { rate: number; names: string[]; positions: number[][] };
}

interface RunResult {
  status: string;
  step: number;
  duration: number;
  cycleTime: number;
}

type Step = Record<string, unknown>;

/** The trajectory in one line, or (verbose) a line per sample: time (s) and joints (rad or m). */
function printTrajectory(report: ProgramReport, verbose: boolean): void {
  const t = report.trajectory;
  if (!t) return;
  const span = t.positions.length > 1 ? (t.positions.length - 1) / t.rate : 0;
  console.log(`trajectory: ${t.positions.length} samples at ${Number(t.rate.toFixed(3))} Hz over ${fmt(span, 3)} s${verbose ? "" : " (--verbose prints them)"}`);
  if (!verbose) return;
  t.positions.forEach((q, i) => console.log(`  t=${fmt(i / t.rate, 3)} s ${t.names.map((n, j) => `${n}=${fmt(q[j] ?? NaN, 4)}`).join(" ")}`));
}

/** The report as the `--json` summary carries it: the trajectory's sample count instead of its samples
 *  unless verbose. */
function reported(report: ProgramReport, verbose: boolean): unknown {
  if (verbose || !report.trajectory) return report;
  const { trajectory, ...rest } = report;
  return { ...rest, trajectory: { rate: trajectory.rate, names: trajectory.names, samples: trajectory.positions.length } };
}

/** The pick-and-place program from `pick` to `place`, approached `lift` m above, back to `home`. */
function pickAndPlace(home: Record<string, number>, pick: Vec3, place: Vec3, lift: number, tcpSpeed: number, down: boolean): { label: string; step: Step }[] {
  const at = (p: Vec3, dz: number): Step => ({ x: p[0], y: p[1], z: p[2] + dz, ...(down ? { orientation: DOWN } : {}) });
  return [
    { label: "PTP above pick", step: { ...at(pick, lift), speed: 0.8 } },
    { label: "LIN down to pick", step: { ...at(pick, 0), motion: "lin", tcpSpeed } },
    { label: "LIN up", step: { ...at(pick, lift), motion: "lin", tcpSpeed } },
    { label: "PTP above place", step: { ...at(place, lift), speed: 0.8 } },
    { label: "LIN down to place", step: { ...at(place, 0), motion: "lin", tcpSpeed } },
    { label: "LIN up", step: { ...at(place, lift), motion: "lin", tcpSpeed } },
    { label: "PTP home", step: { joints: home, acceleration: 0.5 } },
  ];
}

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), { lift: "value", "tcp-speed": "value", verbose: "flag", json: "flag" });
  const verbose = args.options.has("verbose");
  const url = args.positional[0] ?? defaultTdUrl();
  const lift = numberOption(args, "lift", 0.08, 0.01, 0.3);
  const tcpSpeed = numberOption(args, "tcp-speed", 0.2, 0.01, 1);
  const session = await openSession();
  try {
    const twin = await session.connect(url);
    if (!twin.td.actions?.["runProgram"]) throw new Error(`${url}: the TD has no runProgram action (a twin generated before programs existed: generate it again)`);
    const home = await read<Record<string, number>>(twin, "getJointPosition");
    const bounds = cartesianBounds(twin.td);
    const middle: Vec3 = [(bounds.min[0] + bounds.max[0]) / 2, (bounds.min[1] + bounds.max[1]) / 2, 0];
    const closer = (p: Vec3): Vec3 => [middle[0] + 0.7 * (p[0] - middle[0]), middle[1] + 0.7 * (p[1] - middle[1]), p[2]];
    const [pickA, placeA, pickB, placeB] = tableStations(bounds).stations.map((s) => s.p) as [Vec3, Vec3, Vec3, Vec3];
    // the layouts tried in turn until the twin accepts one
    const layouts: { pick: Vec3; place: Vec3; down: boolean }[] = [];
    for (const scale of [false, true]) {
      for (const down of [true, false]) {
        for (const [pick, place] of [[pickA, placeA], [pickB, placeB]] as [Vec3, Vec3][]) {
          layouts.push({ pick: scale ? closer(pick) : pick, place: scale ? closer(place) : place, down });
        }
      }
    }
    let program: { label: string; step: Step }[] = [];
    let report: ProgramReport | null = null;
    let chosen = layouts[0]!;
    for (const layout of layouts) {
      chosen = layout;
      const { pick, place, down } = layout;
      console.log(`pick ${fmtXyz(xyz(pick))}, place ${fmtXyz(xyz(place))}${down ? ", tool pointing down" : ""}, approach ${fmt(lift)} m above, LIN at ${fmt(tcpSpeed)} m/s`);
      program = pickAndPlace(home, pick, place, lift, tcpSpeed, down);
      report = await invoke<ProgramReport>(twin, "validateProgram", { steps: program.map((s) => s.step) });
      if (report.valid) break;
      const k = report.firstFailingStep ?? 0;
      console.log(`  step ${k} (${program[k]?.label}) refused: ${report.steps[k]?.reasons.join("; ")}`);
    }
    if (!report) throw new Error("no layout to try");
    const { pick, place } = chosen;
    const rows = report.steps.map((s) => [String(s.step), program[s.step]?.label ?? "", s.planned ?? "", s.ok ? "ok" : s.reasons.join("; "), `${fmt(s.duration, 3)} s`]);
    console.log(table(["step", "what", "path", "verdict", "duration"], rows));
    printTrajectory(report, verbose);
    if (!report.valid) {
      console.log(`the program is refused at step ${report.firstFailingStep}: nothing runs`);
      process.exitCode = 1;
      if (args.options.has("json")) printJsonSummary({ pick, place, report: reported(report, verbose) });
      return;
    }
    console.log(`cycle time ${fmt(report.cycleTime, 3)} s; running it`);
    const t0 = performance.now();
    const run = await invoke<RunResult>(twin, "runProgram", { steps: program.map((s) => s.step) });
    const wall = (performance.now() - t0) / 1000;
    console.log(`run: ${run.status} in step ${run.step}; simulated ${fmt(run.duration, 3)} s, wall ${fmt(wall, 3)} s (the servient's real-time factor applies)`);
    const back = await read<Record<string, number>>(twin, "getJointPosition");
    const atHome = Object.keys(home).every((j) => Math.abs((back[j] ?? NaN) - (home[j] ?? NaN)) < 1e-6);
    console.log(`back home: ${atHome ? "yes" : "no"}`);
    if (run.status !== "reached" || Math.abs(run.duration - report.cycleTime) > 1e-6 || !atHome) process.exitCode = 1;
    if (args.options.has("json")) printJsonSummary({ pick, place, report: reported(report, verbose), run, wall, atHome });
  } finally {
    await session.close();
  }
}

runScenario("program", USAGE, main);
