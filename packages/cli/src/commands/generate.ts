/**
 * `robwot generate`: wiring of options, output folder, backend, progress and the summary printout. Its own
 * imports are light: an own backend's Python starts once the options are read and the output folder staged,
 * and the modules of the generation itself (the TD builder and validator, the client) load while it starts.
 */
import { relative } from "node:path";
import type { SpawnedBackend } from "@robwot/sim-client";
import { spawnBackend } from "@robwot/sim-client/spawn";
import { describeError } from "../errors.js";
import { exampleHelp } from "../examples.js";
import type { GenerateResult } from "../generate-twin.js";
import { onCleanup } from "../lifecycle.js";
import { preflight } from "../preflight.js";
import { createProgress } from "../progress.js";
import { StagedDir } from "../twin-dir.js";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { DEFAULT_BASE_URL, DEFAULT_SAMPLES, type GenerateOptions, parseGenerateArgs } from "./generate-options.js";

const { Clearance, GripCapture, GripTime, ReachVoxel, Seed } = VALUE_SCHEMAS;

export const USAGE = `Usage: robwot generate <robot.urdf | robot.urdf.xacro | example-name> [options]
       robwot generate --moveit-config DIR [options]

Builds a digital-twin folder: td.json (W3C Thing Description), twin.json, robot.urdf + meshes,
scene.json, workspace.csv (labelled point cloud), workspace.stl (alpha shape), workspace.json,
reachability.csv (reachability map: index per voxel).

Options:
  --scene FILE            scene JSON with obstacles, objects, other robots (default: none)
  --srdf FILE             the robot's SRDF (MoveIt): its <disable_collisions> pairs are never checked; an
                          entry naming a link or joint the robot lacks is skipped with a warning (one mostly
                          of unknown names is refused); its end effector is the default --ee
  --moveit-config DIR     a MoveIt config package as the robot: its URDF or xacro (.setup_assistant, else
                          config/*.urdf.xacro|*.urdf) with its xacro args, its SRDF (config/*.srdf), the
                          velocity limits of config/joint_limits.yaml
  --group NAME            the SRDF planning group: its end effector (or its chain's tip) is the default --ee
  --clearance M           metres every checked path, plan and motion keeps to other bodies
                          (default ${Clearance.default}, ${Clearance.minimum} to ${Clearance.maximum}); in twin.json and the TD
  --samples N             random joint configurations (default ${DEFAULT_SAMPLES})
  --seed N                random seed (default ${Seed.default}; same seed => same workspace.csv)
  --ee LINK               end-effector link (default: the SRDF's end effector, else the last link of the
                          longest chain, fixed tips included)
  --base X,Y,Z[,ROLL,PITCH,YAW]
                          the robot's base pose in the world (scene) frame: metres, and radians as a
                          URDF <origin rpy> (default: the origin, or where --scene's robots entry puts it)
  --tcp X,Y,Z[,ROLL,PITCH,YAW]
                          the tool centre point in the end-effector link's frame (metres, radians): it becomes
                          the end effector (link robwot_tcp) of every Cartesian check, the workspace and the TD
  --tool-mesh FILE        the tool's geometry (STL, OBJ or DAE, metres, in the end-effector link's frame):
                          checked for collisions with the scene and the robot like a link, drawn by the viewer
  --tool-box SX,SY,SZ     the tool as a box (metres) from the end-effector link along its z axis
  --tool-cylinder R,L     the tool as a cylinder (radius, length in metres) likewise; with or without --tool-mesh
  --home J=V,...          the start pose: joints by name (radians or metres), e.g. "joint_2=-0.5,joint_4=1.2";
                          the joints not named stay where the robot loads; over the SRDF's "home" state;
                          an unknown joint or a value outside its limits is refused. generate warns when
                          the start pose collides, naming the bodies in contact
  --limits FILE           a MoveIt-style joint_limits.yaml: its max_velocity values (joints with
                          has_velocity_limits) replace the URDF's <limit velocity> (over a --moveit-config's),
                          min_position/max_position (has_position_limits) its <limit lower upper>
  --out DIR, -o DIR       output folder (default twins/<example name or URDF robot name>);
                          an existing twin there is replaced only on success
  --base-url URL          base URL of the servient for the TD (default ${DEFAULT_BASE_URL})
  --alpha auto|R          alpha-shape radius in metres (default auto)
  --reach-voxel auto|M    voxel side in metres of reachability.csv (${ReachVoxel.minimum} to ${ReachVoxel.maximum}; default auto:
                          1 cm doubled until reached voxels hold 32 collision-free samples on average)
  --workers N             collision-checking processes (default: number of cores)
  --cluster ADDRESS       run sampling, labelling and the reachability map as Ray tasks on an existing
                          Ray cluster: ray://HOST:10001, HOST:6379, or auto (RAY_ADDRESS / this
                          machine's); same files as a local run. Needs ROBWOT_EXTRAS=cluster npm install
  --xacro-arg NAME:=VALUE an argument of the xacro file given as the robot (repeatable); the file is
                          expanded with the xacro package (no ROS install), robot.urdf is the result
  --package-root NAME=DIR resolve package://NAME/... and $(find NAME) (repeatable); also searched: the ROS
                          package holding the file (its package.xml), the folders of ROS_PACKAGE_PATH,
                          then (no package.xml naming it) a folder NAME holding the URDF or beside one
  --couple FOLLOWER=EXPR  a joint that follows others (repeatable): EXPR a linear combination of joints plus a
                          constant, e.g. "joint_4=joint_3-joint_2" or "j5=-0.5*j2+j3+0.1"; it leaves the
                          joint vector (TD inputs, sliders, relay, programs) and is set wherever the linkage
                          puts it (FK, IK, collisions); a rule for a <mimic> joint replaces its tag
  --keep-level LINK       derive the --couple rule that keeps LINK's orientation as at the zero configuration
                          (a parallel-linkage arm's passive joint; the joints tilting LINK must turn about
                          one axis); the rule is printed and recorded in twin.json (repeatable)
  --gripper KIND          a gripper: fingers (parallel fingers driven by the URDF's finger joints, mimic ones
                          following), fingers=JOINT,... (those joints), or suction (a cup at the TCP); the TD
                          gets gripOpen, gripClose and the property gripper; a closed gripper holds the object
                          at its TCP, checked with the robot in every verdict
  --grip-time S           seconds an opening or closing takes (default ${GripTime.default})
  --grip-capture M        how far from the TCP (metres) an object is caught (default ${GripCapture.default})
  --csv-joints            add the joint values to workspace.csv
  --backend ws://HOST:PORT use a running backend instead of starting one
  --json                  print a machine-readable summary on stdout
  --force                 replace --out even if it is not a twin folder, or the twin of another robot

Example robots:
${exampleHelp()}
`;

function printHuman(r: GenerateResult, seconds: number): void {
  const s = r.summary;
  const rel = relative(process.cwd(), r.out) || ".";
  const lines = [
    `robwot: twin "${r.robot.name}" written to ${rel.startsWith("..") ? r.out : rel}/ in ${seconds.toFixed(1)} s`,
    `  robot      ${r.robot.controllable.length} joints (${r.robot.controllable.join(", ")}), end effector ${r.robot.eeLink}`,
    ...(r.robot.couplings.length > 0 ? [`  coupled    ${r.robot.couplings.join("; ")}`] : []),
    `  scene      ${r.obstacles} obstacle(s)${r.objects ? `, ${r.objects} object(s)` : ""}${r.conveyors ? `, ${r.conveyors} conveyor(s)` : ""}${r.sensors ? `, ${r.sensors} sensor(s)` : ""}${r.otherRobots.length ? `, ${r.otherRobots.length} other robot(s): ${r.otherRobots.map((o) => `${o.id} at [${o.basePosition.map((v) => v.toFixed(3)).join(", ")}] m`).join(", ")}` : ""}${r.scene ? ` from ${r.scene}` : ""}`,
    `  workspace  ${s.samples} samples, ${s.collisionFree} collision-free (${((100 * s.collisionFree) / Math.max(1, s.samples)).toFixed(1)}%), ` +
      `${s.method}${s.alpha !== null ? ` alpha ${s.alpha.toFixed(3)} m` : ""}, volume ${s.volume.toFixed(3)} m^3`,
    `  bounds     ${s.bounds.min === null || s.bounds.max === null ? "none (no collision-free sample)" : `min [${s.bounds.min.map((v) => v.toFixed(3)).join(", ")}] max [${s.bounds.max.map((v) => v.toFixed(3)).join(", ")}] m`}`,
    `  reach      ${s.reachability.voxels} voxels of ${s.reachability.voxel.toFixed(3)} m (reachability.csv)`,
    `  td         ${r.td.file} (id ${r.td.id})`,
  ];
  // the warnings were printed as they became known (generate-twin.ts)
  process.stdout.write(`${lines.join("\n")}\n`);
}

/** Validates, generates and reports. Returns the exit code. */
export async function runGenerate(opts: GenerateOptions): Promise<number> {
  const t0 = performance.now();
  const progress = createProgress({ silent: opts.json });
  const inputs = [opts.urdfFile, opts.scene, opts.srdf, ...Object.values(opts.packageRoots)].filter((f): f is string => f !== undefined);
  const staged = StagedDir.create(opts.out, { force: opts.force, inputs });
  const dropStaged = onCleanup(() => staged.discard());
  // an own backend's labelling workers start with it (a cluster run labels elsewhere)
  const warm = opts.cluster === undefined ? (opts.workers ?? 0) : undefined;
  const spawned = opts.backend === undefined ? spawnEarly(warm) : undefined;
  let adopted = false;
  try {
    // while the backend's Python starts: the generation's modules load, the TD validator's too, and the
    // options are checked against the robot's files (a refusal stops the backend started for nothing)
    const [{ BackendGuard }, { generateTwin }, { warmTdValidator }] = await Promise.all([
      import("../backend-guard.js"),
      import("../generate-twin.js"),
      import("../td.js"),
      preflight(opts),
    ]);
    progress.stage("backend");
    adopted = true;
    const [backend] = await Promise.all([BackendGuard.open(opts.backend, warm, spawned), warmTdValidator()]);
    const dropBackend = onCleanup(() => backend.close());
    // on a signal the staged folder goes first (cheap), then the backend stops, then it goes again
    // (the backend may have written into it meanwhile)
    const dropEarly = onCleanup(() => staged.discard());
    try {
      // the backend stops while the final TD is checked; a failure to stop is reported by the close below
      const result = await generateTwin(opts, backend, staged, progress, () => void backend.close().catch(() => undefined)).catch(async (err: unknown) => {
        throw await backend.explain(err);
      });
      const seconds = (performance.now() - t0) / 1000;
      if (opts.json) process.stdout.write(`${JSON.stringify({ ok: true, ...result, seconds }, null, 2)}\n`);
      else printHuman(result, seconds);
      return 0;
    } finally {
      dropEarly();
      dropBackend();
      await backend.close();
    }
  } catch (err) {
    progress.end(false);
    if (opts.json) {
      const { message, code } = describeError(err);
      process.stdout.write(`${JSON.stringify({ ok: false, error: { code, message } }, null, 2)}\n`);
    }
    throw err;
  } finally {
    if (!adopted) spawned?.kill();
    dropStaged();
    staged.discard();
  }
}

/** The own backend's process, started now; undefined where it cannot start (the launch then says why). */
function spawnEarly(warmWorkers: number | undefined): SpawnedBackend | undefined {
  try {
    return spawnBackend(warmWorkers !== undefined ? { warmWorkers } : {});
  } catch {
    return undefined;
  }
}

export async function run(argv: string[]): Promise<number> {
  return runGenerate(parseGenerateArgs(argv));
}
