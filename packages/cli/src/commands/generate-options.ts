/**
 * `robwot generate` options: parsed with node's `util.parseArgs` and fully validated before anything is
 * started (no backend, no folder), so a typo costs milliseconds and leaves nothing behind.
 */
import { existsSync, readFileSync, statSync } from "node:fs";
import { basename, join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { existingFile, parseAlpha, parseInteger, parseNumber, parsePackageRoots, parseUrl, usageError } from "../args.js";
import type { GripperDecl } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { CliError } from "../errors.js";

const { Clearance, CouplingRule, CouplingRules, ReachVoxel, Samples, Seed, Workers } = VALUE_SCHEMAS;
/** The clearance (m) a robot keeps unless told (the backend contract's default). */
export const DEFAULT_CLEARANCE = Clearance.default;
import { type BasePose, parseBase, parseTcp, parseToolShape, type ToolShape } from "./pose-options.js";
import { EXAMPLE_NAMES, type ExampleRobot, findExample, looksLikeExampleName } from "../examples.js";


export interface GenerateOptions {
  /** Exactly one of `urdfFile` (absolute path) and `example` is set. */
  urdfFile?: string;
  /** When `urdfFile` is a xacro file (`*.xacro`): its arguments (`--xacro-arg NAME:=VALUE`), expanded by the backend */
  xacroArgs?: Record<string, string>;
  /** `--moveit-config DIR` (absolute): the robot, its xacro args and SRDF from a MoveIt config package (instead of `urdfFile`) */
  moveitConfig?: string;
  /** `--group NAME`: the SRDF planning group whose end effector is the default `--ee` */
  group?: string;
  example?: ExampleRobot;
  scene?: string;
  /** SRDF file (absolute): its disabled collision pairs are never checked; copied into the twin */
  srdf?: string;
  /** m kept to other bodies by checked paths, plans and motions */
  clearance: number;
  samples: number;
  seed: number;
  ee?: string;
  out: string;
  baseUrl: string;
  alpha: "auto" | number;
  /** voxel side (m) of reachability.csv, or "auto" (chosen from the samples by the backend) */
  reachVoxel: "auto" | number;
  workers?: number;
  /** Ray cluster address ("auto", ray://host:10001, host:port): workspace chunks run there as Ray tasks */
  cluster?: string;
  packageRoots: Record<string, string>;
  /** `--base`: the robot's base pose in the world (scene) frame; absent = the origin, or the scene's placement */
  base?: BasePose;
  /** `--tcp`: X, Y, Z (m), ROLL, PITCH, YAW (rad) of the tool centre point from the end-effector link */
  tcp?: number[];
  /** `--tool-mesh`: the tool's geometry in the end-effector link's frame */
  toolMesh?: string;
  /** `--tool-box` / `--tool-cylinder`: the tool as a primitive from the flange along its z axis */
  toolShape?: ToolShape;
  /** `--limits`: a MoveIt-style joint_limits.yaml whose velocity limits replace the URDF's */
  limits?: string;
  /** `--couple FOLLOWER=EXPR` (repeatable): joints that follow others, read by the backend (`robot.load` `couplings`) */
  couplings: string[];
  /** `--keep-level LINK` (repeatable): links whose orientation the derived couplings keep */
  keepLevel: string[];
  /** `--home J=V,...`: the start pose's joints (rad or m) by name, over the SRDF's `home` state; checked
   * against the robot's joints and limits once it is loaded */
  home?: Record<string, number>;
  /** `--gripper fingers[=J,...]|suction` with `--grip-time`, `--grip-capture`: declared to the backend, recorded */
  gripper?: GripperDecl;
  csvJoints: boolean;
  backend?: string;
  json: boolean;
  force: boolean;
}

export const GENERATE_OPTIONS = {
  scene: { type: "string" },
  srdf: { type: "string" },
  clearance: { type: "string" },
  samples: { type: "string" },
  seed: { type: "string" },
  ee: { type: "string" },
  out: { type: "string", short: "o" },
  "base-url": { type: "string" },
  alpha: { type: "string" },
  "reach-voxel": { type: "string" },
  workers: { type: "string" },
  cluster: { type: "string" },
  "package-root": { type: "string", multiple: true },
  base: { type: "string" },
  tcp: { type: "string" },
  "tool-box": { type: "string" },
  "tool-cylinder": { type: "string" },
  limits: { type: "string" },
  "tool-mesh": { type: "string" },
  "xacro-arg": { type: "string", multiple: true },
  couple: { type: "string", multiple: true },
  "keep-level": { type: "string", multiple: true },
  home: { type: "string" },
  gripper: { type: "string" },
  "grip-time": { type: "string" },
  "grip-capture": { type: "string" },
  "moveit-config": { type: "string" },
  group: { type: "string" },
  "csv-joints": { type: "boolean" },
  backend: { type: "string" },
  json: { type: "boolean" },
  force: { type: "boolean" },
} as const;

export const DEFAULT_SAMPLES = Samples.default;
export const DEFAULT_BASE_URL = "http://localhost:8080/";

/** File-system friendly name: lower case, `[a-z0-9_-]`. */
export function slugify(name: string): string {
  const s = name.toLowerCase().replace(/[^a-z0-9_-]+/g, "-").replace(/^-+|-+$/g, "");
  return s === "" ? "robot" : s;
}

/** The `<robot name="...">` of a URDF, read cheaply (the backend parses it properly later). */
function urdfRobotName(file: string): string | undefined {
  try {
    const head = readFileSync(file, "utf8").slice(0, 65536);
    return /<robot\b[^>]*\bname\s*=\s*["']([^"']+)["']/.exec(head)?.[1];
  } catch {
    return undefined;
  }
}

/** `--xacro-arg NAME:=VALUE` (repeatable, xacro's own syntax) → `{NAME: VALUE}`; a name given twice is refused. */
export function parseXacroArgs(values: string[] | undefined): Record<string, string> {
  const args: Record<string, string> = {};
  for (const v of values ?? []) {
    const m = /^([A-Za-z_][A-Za-z0-9_]*):=(.*)$/s.exec(v);
    if (!m) throw new CliError(`--xacro-arg must look like NAME:=VALUE (e.g. prefix:=left_), got "${v}"`);
    const [, name, value] = m as unknown as [string, string, string];
    if (name in args) throw new CliError(`--xacro-arg ${name} given twice`);
    args[name] = value;
  }
  return args;
}

function existingDir(option: string, path: string): string {
  const abs = resolve(path);
  if (!existsSync(abs) || !statSync(abs).isDirectory()) throw new CliError(`--${option}: folder not found: ${abs}`);
  return abs;
}

function isFile(path: string): boolean {
  return existsSync(path) && statSync(path).isFile();
}

function parseSceneFile(path: string): string {
  const abs = existingFile("scene file", path);
  let text: string;
  try {
    text = readFileSync(abs, "utf8");
  } catch (err) {
    throw new CliError(`cannot read scene file ${abs}: ${(err as Error).message}`, "E_SCENE", 1);
  }
  try {
    JSON.parse(text);
  } catch (err) {
    throw new CliError(`scene file ${abs} is not valid JSON: ${(err as Error).message}`, "E_SCENE", 1);
  }
  return abs;
}

const parseGenerateValues = (argv: string[]) => parseArgs({ args: argv, options: GENERATE_OPTIONS, allowPositionals: true, strict: true });
type GenerateValues = ReturnType<typeof parseGenerateValues>["values"];

/** Where the robot comes from: a URDF (or xacro) file, an example, or a MoveIt config package. */
interface RobotSource {
  robotArg: string;
  urdfFile?: string;
  example?: ExampleRobot;
  moveitConfig?: string;
}

/**
 * `robwot generate` options, every one checked here in the order the user reads them, before anything
 * starts: the first refusal is the one reported.
 */
export function parseGenerateArgs(argv: string[]): GenerateOptions {
  let parsed;
  try {
    parsed = parseGenerateValues(argv);
  } catch (err) {
    throw usageError(err, "generate", Object.keys(GENERATE_OPTIONS));
  }
  const { values, positionals } = parsed;
  const { robotArg, urdfFile, example, moveitConfig } = parseRobotSource(values, positionals);
  const { samples, seed, workers, alpha, cluster, reachVoxel } = parseSampling(values);
  const clearance = parseNumber("clearance", values.clearance, DEFAULT_CLEARANCE, Clearance.minimum, Clearance.maximum);
  const packageRoots = parsePackageRoots(values["package-root"]);
  const base = parseBase(values.base);
  const tcp = parseTcp(values.tcp);
  const toolMesh = values["tool-mesh"] === undefined ? undefined : existingFile("tool mesh", values["tool-mesh"]);
  const toolShape = parseToolShape(values["tool-box"], values["tool-cylinder"]);
  const limits = values.limits === undefined ? undefined : existingFile("joint limits file", values.limits);
  const xacroArgs = parseXacroArgs(values["xacro-arg"]);
  const isXacro = (urdfFile?.endsWith(".xacro") ?? false) || moveitConfig !== undefined;
  if (!isXacro && Object.keys(xacroArgs).length > 0) {
    throw new CliError(`--xacro-arg is for a xacro file (robot.urdf.xacro); ${urdfFile ?? robotArg} is not one`);
  }
  const baseUrlObj = parseUrl("base-url", values["base-url"] ?? DEFAULT_BASE_URL, ["http", "https"]) as URL;
  const baseUrl = baseUrlObj.href.endsWith("/") ? baseUrlObj.href : `${baseUrlObj.href}/`;
  const backend = parseUrl("backend", values.backend, ["ws", "wss"])?.href;
  const scene = values.scene === undefined ? undefined : parseSceneFile(values.scene);
  checkEndEffector(values, moveitConfig);
  const { couplings, keepLevel } = parseCouplings(values);
  const home = parseHome(values.home);
  const gripper = parseGripper(values);
  const out = resolve(values.out ?? join("twins", slugify(robotName({ robotArg, urdfFile, example, moveitConfig }))));
  return {
    ...(urdfFile ? { urdfFile } : {}),
    ...(isXacro ? { xacroArgs } : {}),
    ...(moveitConfig !== undefined ? { moveitConfig } : {}),
    ...(values.group !== undefined ? { group: values.group } : {}),
    ...(example ? { example } : {}),
    ...(scene ? { scene } : {}),
    ...(values.srdf !== undefined ? { srdf: existingFile("SRDF file", values.srdf) } : {}),
    clearance,
    samples,
    seed,
    ...(values.ee !== undefined ? { ee: values.ee } : {}),
    out,
    baseUrl,
    alpha,
    reachVoxel,
    ...(workers !== undefined ? { workers } : {}),
    ...(cluster !== undefined ? { cluster } : {}),
    packageRoots,
    ...(base ? { base } : {}),
    ...(tcp ? { tcp } : {}),
    ...(toolMesh ? { toolMesh } : {}),
    ...(toolShape ? { toolShape } : {}),
    ...(limits ? { limits } : {}),
    couplings,
    keepLevel,
    ...(home !== undefined ? { home } : {}),
    ...(gripper !== undefined ? { gripper } : {}),
    csvJoints: values["csv-joints"] ?? false,
    ...(backend ? { backend } : {}),
    json: values.json ?? false,
    force: values.force ?? false,
  };
}

/** The robot: one positional (a file or an example name) or `--moveit-config`, never both. */
function parseRobotSource(values: GenerateValues, positionals: string[]): RobotSource {
  const moveitConfig = values["moveit-config"] === undefined ? undefined : existingDir("moveit-config", values["moveit-config"]);
  if (moveitConfig !== undefined && positionals.length > 0) {
    throw new CliError(`--moveit-config names the robot already: give it or a robot (${positionals.join(" ")}), not both`);
  }
  if (moveitConfig === undefined && positionals.length !== 1) {
    throw new CliError(
      positionals.length === 0
        ? `missing robot: give a URDF file or an example name (${EXAMPLE_NAMES.join(", ")})`
        : `expected one robot, got ${positionals.length}: ${positionals.join(" ")}`,
    );
  }
  const robotArg = positionals[0] ?? "";
  const known = findExample(robotArg);
  // with a MoveIt config, the robot file is found in the package by the backend
  if (moveitConfig !== undefined) return { robotArg, moveitConfig };
  if (known && !isFile(robotArg)) return { robotArg, example: known };
  if (isFile(robotArg) || !looksLikeExampleName(robotArg)) return { robotArg, urdfFile: existingFile("URDF file", robotArg) };
  throw new CliError(`unknown example robot "${robotArg}" and no such file (examples: ${EXAMPLE_NAMES.join(", ")})`);
}

/** How the workspace is sampled: count, seed, local workers or a Ray cluster, alpha, reachability voxel. */
function parseSampling(values: GenerateValues): Pick<GenerateOptions, "samples" | "seed" | "workers" | "alpha" | "cluster" | "reachVoxel"> {
  const samples = parseInteger("samples", values.samples, Samples.default, Samples.minimum, Samples.maximum);
  const seed = parseInteger("seed", values.seed, Seed.default, Seed.minimum, Seed.maximum);
  const workers = values.workers === undefined ? undefined : parseInteger("workers", values.workers, Workers.minimum, Workers.minimum, Workers.maximum);
  const alpha = parseAlpha(values.alpha);
  const cluster = values.cluster?.trim();
  if (cluster === "") throw new CliError('--cluster needs a Ray address ("auto" or ray://host:10001)');
  if (cluster !== undefined && workers !== undefined) throw new CliError("--workers is for the local pool: give it or --cluster, not both");
  const reachVoxel = values["reach-voxel"] === undefined || values["reach-voxel"] === "auto" ? "auto" : parseNumber("reach-voxel", values["reach-voxel"], 0, ReachVoxel.minimum, ReachVoxel.maximum);
  return { samples, seed, workers, alpha, cluster, reachVoxel };
}

/** `--ee` names a link; `--group` names a planning group of an SRDF that is given. */
function checkEndEffector(values: GenerateValues, moveitConfig: string | undefined): void {
  if (values.ee !== undefined && values.ee.trim() === "") throw new CliError("--ee must name a link");
  if (values.group !== undefined && values.group.trim() === "") throw new CliError("--group must name a planning group of the SRDF");
  if (values.group !== undefined && values.srdf === undefined && moveitConfig === undefined) {
    throw new CliError("--group names a planning group of an SRDF: give --srdf FILE or --moveit-config DIR");
  }
}

/**
 * `--couple FOLLOWER=EXPR` and `--keep-level LINK`, each repeatable: their shape checked here (the
 * contract's `CouplingRule`), the rules themselves by the backend against the robot's joints.
 */
function parseCouplings(values: GenerateValues): Pick<GenerateOptions, "couplings" | "keepLevel"> {
  const couplings = (values.couple ?? []).map((c) => c.trim());
  if (couplings.length > CouplingRules.maxItems) throw new CliError(`--couple: at most ${CouplingRules.maxItems} rules, got ${couplings.length}`);
  for (const c of couplings) {
    if (c.length > CouplingRule.maxLength || !new RegExp(CouplingRule.pattern).test(c)) {
      throw new CliError(`--couple must be FOLLOWER=EXPR (e.g. "joint_4=joint_3-joint_2", at most ${CouplingRule.maxLength} characters), got "${c.slice(0, 80)}"`);
    }
  }
  const keepLevel = (values["keep-level"] ?? []).map((l) => l.trim());
  if (keepLevel.some((l) => l === "")) throw new CliError("--keep-level must name a link");
  return { couplings, keepLevel };
}

/**
 * `--gripper fingers[=JOINT,...]` (parallel fingers: the named finger joints, default every one the backend
 * finds) or `--gripper suction` (a cup at the TCP), `--grip-time S` and `--grip-capture M` (the contract's
 * `GripTime`, `GripCapture`); the joints are checked against the robot by the backend (`gripper.configure`).
 */
function parseGripper(values: GenerateValues): GripperDecl | undefined {
  const { GripTime, GripCapture } = VALUE_SCHEMAS;
  if (values.gripper === undefined) {
    if (values["grip-time"] !== undefined || values["grip-capture"] !== undefined) throw new CliError("--grip-time and --grip-capture need --gripper");
    return undefined;
  }
  const m = /^(fingers|suction)(?:=(.+))?$/.exec(values.gripper.trim());
  const joints = m?.[2]?.split(",").map((j) => j.trim());
  if (!m || (m[1] === "suction" && joints !== undefined) || joints?.some((j) => j === "")) {
    throw new CliError(`--gripper must be fingers, fingers=JOINT,... or suction, got "${values.gripper.slice(0, 80)}"`);
  }
  const time = parseNumber("grip-time", values["grip-time"], GripTime.default, GripTime.minimum, GripTime.maximum);
  const capture = parseNumber("grip-capture", values["grip-capture"], GripCapture.default, GripCapture.minimum, GripCapture.maximum);
  return { kind: m[1] as GripperDecl["kind"], ...(joints !== undefined ? { joints } : {}), time, capture };
}

/** The robot's name, which names the default output folder: the example's, the URDF's, or the file's. */
function robotName({ urdfFile, example, moveitConfig }: RobotSource): string {
  const declared = urdfFile ? urdfRobotName(urdfFile) : undefined;
  // a xacro's name may itself be an expression: then the file name it has
  const fileName = moveitConfig !== undefined ? basename(moveitConfig).replace(/_moveit_config$/, "") : basename(urdfFile ?? "robot").replace(/(\.urdf)?(\.xacro)?$/, "");
  return example?.name ?? (declared?.includes("$") ? undefined : declared) ?? fileName;
}

/** `--home J=V,...`: joint names with finite values (rad or m), each named once; which joints the robot
 * has and their limits are checked once it is loaded (`start-state.ts`). */
export function parseHome(value: string | undefined): Record<string, number> | undefined {
  if (value === undefined) return undefined;
  const out: Record<string, number> = {};
  for (const item of value.split(",")) {
    const m = /^\s*([^=\s]+)\s*=\s*(\S+)\s*$/.exec(item);
    const v = m ? Number(m[2]) : Number.NaN;
    if (!m || !Number.isFinite(v)) throw new CliError(`--home must be JOINT=VALUE,... (radians or metres by joint name), got "${item.slice(0, 80)}" in "${value.slice(0, 200)}"`);
    if (Object.hasOwn(out, m[1]!)) throw new CliError(`--home names joint ${m[1]} twice`);
    out[m[1]!] = v;
  }
  return out;
}
