/**
 * The generate pipeline (Contract 2): URDF (+ scene) → complete twin folder, written into a staged
 * temporary folder and moved into place only when everything, TD validation included, succeeded.
 * Shared by `robwot generate` and `robwot demo`.
 */
import { copyFileSync, existsSync, realpathSync, rmSync, writeFileSync } from "node:fs";
import { join, resolve } from "node:path";
import { buildThingModel, type GripperDecl, TWIN_FILES, TWIN_FOLDERS } from "@robwot/core";
import type { RobotLoadProgressNotification, RobotModel, SimClient, WorkspaceSummary, WorldList } from "@robwot/sim-client";
import type { BackendGuard } from "./backend-guard.js";
import { buildTd, compileTdSchemasNow, tdErrorsMessage } from "./td.js";
import type { GenerateOptions } from "./commands/generate-options.js";
import { CliError, describeError } from "./errors.js";
import { exampleUrdfPath } from "./examples.js";
import { meshProgress, SLOW_LOAD, SLOW_LOAD_MS } from "./mesh-progress.js";
import { type ProgressSink, whileSlow } from "./progress.js";
import { prepareRosInput, type RosInput } from "./ros-input.js";
import { sceneDocument } from "./scene-doc.js";
import { checkStart, type Home, overlapWarnings, Warnings } from "./start-state.js";
import { StagedDir } from "./twin-dir.js";
import { noteSurface, refuseDegenerate } from "./workspace-verdict.js";
import { VERSION } from "./version.js";

export interface GenerateResult {
  out: string;
  /** `couplings`: each joint that follows others, as `FOLLOWER=EXPR` (mimic tags included) */
  robot: { name: string; id: string; urdf: string; eeLink: string; controllable: string[]; couplings: string[] };
  scene: string | null;
  obstacles: number;
  /** the scene's objects (README "Objects"), written to scene.json where they rest */
  objects: number;
  /** the scene's conveyors and sensors (README "Conveyors and sensors"), kept in scene.json */
  conveyors: number;
  sensors: number;
  summary: WorkspaceSummary;
  td: { id: string; title: string; file: string };
  seconds: number;
  /** the scene's other robots (id, base position in m) */
  otherRobots: { id: string; basePosition: number[] }[];
  /** what the user should know, each printed as soon as it is known: what reading the robot skipped or
   * guessed (SRDF entries of unknown names, packages taken by their folder's name), a start pose in
   * contact, robots of the scene this one can touch */
  warnings: string[];
}

/** Same shape as the real summary; only the numbers differ (used to pre-validate the TD). */
function placeholderSummary(opts: GenerateOptions): WorkspaceSummary {
  return {
    samples: opts.samples,
    collisionFree: 0,
    bounds: { min: [-1, -1, -1], max: [1, 1, 1] },
    alpha: null,
    method: "alpha-shape",
    volume: 0,
    seed: opts.seed,
    reachability: { file: TWIN_FILES.reachability, voxel: 0.01, voxels: 0, directions: 64, approachAxis: "z" },
    timings: { sample: 0, collide: 0, alpha: 0, write: 0 },
    versions: {},
  };
}

function writeJson(file: string, value: unknown): void {
  writeFileSync(file, `${JSON.stringify(value, null, 2)}\n`);
}

/** Resolves the URDF to load: a file given by the user, an example robot, or (`--moveit-config`) none yet. */
function urdfPath(opts: GenerateOptions, pybulletData: string): string {
  if (opts.urdfFile) return opts.urdfFile;
  if (opts.moveitConfig !== undefined) return opts.moveitConfig;
  if (!opts.example) throw new CliError("no robot given");
  const file = exampleUrdfPath(opts.example, pybulletData);
  if (!existsSync(file)) {
    throw new CliError(`example robot "${opts.example.name}" not found at ${file} (is pybullet_data installed?)`, "E_FILE_NOT_FOUND", 1);
  }
  return file;
}

function samePath(a: string, b: string): boolean {
  try {
    return realpathSync(a) === realpathSync(b);
  } catch {
    return resolve(a) === resolve(b);
  }
}

/**
 * The scene's other robots exported into the twin folder (`robots/<id>/`: URDF, meshes, convex parts), so
 * the folder is self-contained and `serve` loads them from inside it; returns each id's URDF path there.
 */
async function exportSceneRobots(sim: SimClient, world: WorldList, ownRobot: string, dir: string): Promise<Map<string, string>> {
  const out = new Map<string, string>();
  for (const r of world.robots.filter((x) => x.id !== ownRobot)) {
    const folder = `${TWIN_FOLDERS.sceneRobots}/${r.id}`;
    await sim.exportRobot({ robot: r.id, outDir: join(dir, folder) });
    out.set(r.id, `${folder}/${TWIN_FILES.urdf}`);
  }
  return out;
}

/** Samples from which the TD is also validated before the labelling ends (placeholder bounds), so that a model
 * that cannot make a valid TD fails before a long labelling. Below, the validation would only take CPU from
 * the labelling workers to fail a few seconds earlier; a cluster run always validates early. */
const EARLY_TD_SAMPLES = 1_000_000;

/**
 * Loads the scene, then the robot. A scene may place robots itself (`robots: [{urdf, basePosition, ...}]`):
 * when one of them is the robot being generated, that one is the twin (reloaded with `--ee` if given, at
 * the scene's pose); every other robot is an obstacle.
 */
async function loadRobotInScene(
  opts: GenerateOptions,
  sim: SimClient,
  urdf: string,
  packageRoots: Record<string, string>,
  onMesh: (mesh: RobotLoadProgressNotification) => void,
  source: string = urdf,
  accelerations?: Record<string, number>,
  jerks?: Record<string, number>,
): Promise<RobotModel> {
  // the acceleration and jerk limits are checked against the robot's joints here, as serve will load them
  const srdf = {
    ...(opts.srdf !== undefined ? { srdf: opts.srdf } : {}),
    clearance: opts.clearance,
    ...(accelerations !== undefined ? { accelerationLimits: accelerations } : {}),
    ...(jerks !== undefined ? { jerkLimits: jerks } : {}),
  };
  const base = opts.base ? { basePosition: opts.base.position, baseOrientation: opts.base.orientation } : {};
  const coupled = {
    ...(opts.couplings.length > 0 ? { couplings: opts.couplings } : {}),
    ...(opts.keepLevel.length > 0 ? { keepLevel: opts.keepLevel } : {}),
  };
  const own = { urdf, ...(opts.ee !== undefined ? { eeLink: opts.ee } : {}), packageRoots, ...srdf, ...base, ...coupled };
  if (!opts.scene) return sim.loadRobot(own, { onProgress: onMesh });
  await sim.loadScene({ path: opts.scene, packageRoots });
  // the scene names the user's file; the robot loaded may be a copy of it (with a tool, or expanded)
  const placed = (await sim.listWorld()).robots.find((r) => samePath(r.urdf, urdf) || samePath(r.urdf, source));
  if (!placed) return sim.loadRobot(own, { onProgress: onMesh });
  if (opts.base) {
    // two placements of one robot: neither silently wins
    throw new CliError(
      `--base places the robot, but the scene ${opts.scene} places it too (robots entry "${placed.id}" at [${placed.basePosition.join(", ")}]): give one of them`,
      "E_USAGE",
      2,
    );
  }
  await sim.removeRobot({ robot: placed.id });
  return sim.loadRobot({
    urdf,
    id: placed.id,
    basePosition: placed.basePosition,
    baseOrientation: placed.baseOrientation,
    eeLink: opts.ee ?? placed.eeLink,
    packageRoots,
    ...srdf,
    ...coupled,
  }, { onProgress: onMesh });
}

/**
 * Runs the whole pipeline against an open backend whose world is empty. `staged` must have been created
 * by the caller (before starting the backend, so output problems are reported first); it is committed
 * on success and left for the caller to discard on failure. `done` is called once the backend is no
 * longer needed (before the final TD checks, which the caller's stopping backend then runs beside).
 */
export async function generateTwin(
  opts: GenerateOptions,
  backend: BackendGuard,
  staged: StagedDir,
  progress: ProgressSink,
  done: () => void = () => undefined,
): Promise<GenerateResult> {
  const t0 = performance.now();
  progress.stage("load");
  const { sim } = backend;
  const source = urdfPath(opts, backend.pybulletData);
  // The backend starts its collision workers while it loads the scene.
  // Only a head start: should it fail, workspace.generate starts the pool itself and reports any real failure.
  if (opts.cluster === undefined) await sim.warmUp(opts.workers === undefined ? {} : { workers: opts.workers }).catch(() => undefined);
  const input = await prepareRosInput(opts, sim, source);
  // from here on the robot is the prepared one: the SRDF and end effector the input chose
  const { srdf: _srdf, ee: _ee, ...rest } = opts;
  const effective: GenerateOptions = { ...rest, ...(input.srdf !== undefined ? { srdf: input.srdf } : {}), ...(input.ee !== undefined ? { ee: input.ee } : {}) };
  let keep = false;
  try {
    return await generateFrom(effective, sim, staged, progress, t0, input, done);
  } catch (err) {
    const { message, code } = describeError(err);
    if (input.expandedDir !== undefined && message.includes(input.urdf)) {
      keep = true; // the error names a line of the expanded file: it stays for the user to read
      throw new CliError(`${message} (the URDF expanded from ${input.source}, kept there)`, code, 1);
    }
    throw err;
  } finally {
    if (input.expandedDir !== undefined && !keep) rmSync(input.expandedDir, { recursive: true, force: true });
    if (input.toolDir !== undefined) rmSync(input.toolDir, { recursive: true, force: true });
  }
}

async function generateFrom(
  opts: GenerateOptions,
  sim: SimClient,
  staged: StagedDir,
  progress: ProgressSink,
  t0: number,
  input: RosInput,
  done: () => void,
): Promise<GenerateResult> {
  const { source, urdf, packageRoots } = input;
  const meshes = meshProgress(progress);
  const model = await whileSlow(loadRobotInScene(opts, sim, urdf, packageRoots, meshes.onMesh, source, input.accelerations, input.jerks), SLOW_LOAD_MS, () => {
    if (!meshes.seen()) progress.info(SLOW_LOAD);
  });
  staged.refuseOtherRobot(model.name, opts.force);
  for (const c of model.couplings.filter((k) => k.source === "keep-level")) {
    progress.info(`--keep-level: derived --couple "${c.expression}" (recorded in twin.json)`);
  }
  // what the user should know is said before sampling whenever it is known by then
  const warnings = new Warnings(progress);
  warnings.say(inputWarnings(input, model));
  const home = await checkStart(sim, model, opts.home, input.home, warnings);
  if (opts.gripper !== undefined) await declareGripper(sim, model, opts.gripper);
  const world = await sim.listWorld();
  const obstacles = world.obstacles;
  const others = world.robots.filter((r) => r.id !== model.id);
  warnings.say(overlapWarnings(model, others));

  // Generation starts first: the backend serves the export (and the CLI writes its files) meanwhile.
  const generating = startGenerating(opts, sim, model, staged.tmp, progress);
  await sim.exportRobot({ robot: model.id, outDir: staged.tmp });
  if (opts.srdf !== undefined) copyFileSync(opts.srdf, join(staged.tmp, TWIN_FILES.srdf));
  const scene = sceneDocument(world, model.id, staged.tmp, opts.scene, await exportSceneRobots(sim, world, model.id, staged.tmp));
  writeJson(join(staged.tmp, TWIN_FILES.scene), scene);
  writeManifest(staged.tmp, model, opts, input, home);

  // While the backend samples a long run: validate the TD's structure (placeholder bounds), so a model that
  // cannot make a valid TD fails fast (the validator's modules were loaded while the backend started).
  if (opts.samples >= EARLY_TD_SAMPLES || opts.cluster !== undefined) {
    const early = await (async () => buildTd(model, placeholderSummary(opts), scene, opts.baseUrl, input.tool, opts.gripper).validate())().catch(
      (err: unknown) => [err instanceof Error ? err.message : String(err)],
    );
    if (early.length > 0) throw new CliError(`generated Thing Description is invalid: ${tdErrorsMessage(early)}`, "E_TD_INVALID", 1);
  }
  const summary = await generating;
  const overlaps = overlapWarnings(model, others, summary);
  warnings.say(overlaps);
  await refuseDegenerate(summary, staged.tmp, sim, model, overlaps);
  done(); // nothing below asks the backend
  writeJson(join(staged.tmp, TWIN_FILES.summary), summary);
  writeJson(join(staged.tmp, TWIN_FILES.thingModel), buildThingModel());
  noteSurface(summary, progress);

  progress.stage("td");
  const td = buildTd(model, summary, scene, opts.baseUrl, input.tool, opts.gripper);
  const errors = await td.validate();
  if (errors.length > 0) throw new CliError(`generated Thing Description is invalid: ${tdErrorsMessage(errors)}`, "E_TD_INVALID", 1);
  writeJson(join(staged.tmp, TWIN_FILES.td), td.td);

  staged.commit();
  progress.end();
  return {
    out: staged.out,
    robot: { name: model.name, id: model.id, urdf: source, eeLink: model.eeLink, controllable: model.controllable, couplings: model.couplings.map((c) => c.expression) },
    scene: opts.scene ?? null,
    obstacles: obstacles.length,
    objects: world.objects.length,
    conveyors: world.conveyors.length,
    sensors: world.sensors.length,
    summary,
    td: { id: td.td.id, title: td.td.title, file: join(staged.out, TWIN_FILES.td) },
    seconds: (performance.now() - t0) / 1000,
    otherRobots: others.map((r) => ({ id: r.id, basePosition: r.basePosition })),
    warnings: warnings.all,
  };
}

/** The workspace generation, started: the caller exports the robot and checks the TD while it runs. */
function startGenerating(opts: GenerateOptions, sim: SimClient, model: RobotModel, dir: string, progress: ProgressSink): Promise<WorkspaceSummary> {
  const generating = sim.generateWorkspace(
    {
      robot: model.id,
      samples: opts.samples,
      seed: opts.seed,
      ...(opts.workers !== undefined ? { workers: opts.workers } : {}),
      ...(opts.cluster !== undefined ? { cluster: opts.cluster } : {}),
      alpha: opts.alpha,
      outDir: dir,
      csvJoints: opts.csvJoints,
      reachVoxel: opts.reachVoxel,
    },
    {
      onProgress: (p) => {
        // the alpha shape takes one core, the labelling took all: the TD validator compiles its schema beside it
        if (p.stage === "alpha") compileTdSchemasNow();
        progress.update(p.stage, p.done, p.total);
      },
    },
  );
  // Abandoned (and rejected when the backend stops) if the export or the early TD check fails.
  generating.catch(() => undefined);
  return generating;
}

/** twin.json: the robot as `serve` loads it again, and what it was made from. */
function writeManifest(dir: string, model: RobotModel, opts: GenerateOptions, input: RosInput, home: Home | undefined): void {
  const rules = model.couplings.filter((c) => c.source !== "mimic").map((c) => c.expression);
  writeJson(join(dir, TWIN_FILES.manifest), {
    version: 1,
    robot: {
      urdf: TWIN_FILES.urdf,
      eeLink: model.eeLink,
      basePosition: model.basePosition ?? [0, 0, 0],
      baseOrientation: model.baseOrientation ?? [0, 0, 0, 1],
      name: model.name,
      ...(opts.srdf !== undefined ? { srdf: TWIN_FILES.srdf } : {}),
      clearance: model.clearance,
      // the xacro file robot.urdf was expanded from (its name only: twin.json is served) and its arguments
      ...(input.xacro ? { xacro: input.xacro } : {}),
      // the SRDF planning group chosen with --group (its end effector is eeLink unless --ee)
      ...(input.group !== undefined ? { group: input.group } : {}),
      // --home, else the SRDF's home state: the pose serve starts the twin in
      ...(home !== undefined ? { home } : {}),
      // --limits: the joint_limits.yaml whose velocities robot.urdf carries
      ...(input.limits !== undefined ? { limits: input.limits } : {}),
      // its (or a MoveIt config's) accelerations, which a URDF cannot carry: serve passes them to robot.load
      ...(input.accelerations !== undefined ? { accelerations: input.accelerations } : {}),
      ...(input.jerks !== undefined ? { jerks: input.jerks } : {}),
      // --tcp / --tool-mesh: robot.urdf carries the tool (links robwot_tool, robwot_tcp); eeLink is the TCP
      ...(input.tool !== undefined ? { tool: input.tool } : {}),
      // --couple rules and those --keep-level derived (robot.urdf's own <mimic> tags aside): serve loads them
      ...(rules.length > 0 ? { couplings: rules } : {}),
      // --gripper: serve declares it to the backend (gripper.configure) when it loads the robot
      ...(opts.gripper !== undefined ? { gripper: opts.gripper } : {}),
    },
    scene: TWIN_FILES.scene,
    generatedAt: new Date().toISOString(),
    tool: `robwot ${VERSION}`,
  });
}

/** `--gripper` declared to the backend as serve will: a robot without the finger joints is refused here. */
async function declareGripper(sim: SimClient, model: RobotModel, g: GripperDecl): Promise<void> {
  type Joints = Parameters<SimClient["configureGripper"]>[0]["joints"];
  await sim.configureGripper({ robot: model.id, kind: g.kind, time: g.time, capture: g.capture, ...(g.joints !== undefined ? { joints: g.joints as Joints } : {}) }).catch((err: unknown) => {
    throw new CliError(`--gripper: ${err instanceof Error ? err.message : String(err)}`, "E_USAGE", 2);
  });
}

/** What reading the robot skipped or guessed, each once (`robot.readSrdf` and `robot.load` both report the
 * SRDF's skipped entries; `robot.load` the packages it took by their folder's name). */
function inputWarnings(input: RosInput, model: RobotModel): string[] {
  return [...new Set([...(input.srdfWarnings ?? []), ...(model.warnings ?? [])])];
}
