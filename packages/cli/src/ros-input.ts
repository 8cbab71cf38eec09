/**
 * The robot as ROS users hand it over, made ready for `robot.load`: a xacro file expanded (`--xacro-arg`),
 * a MoveIt config package read (`--moveit-config`: its URDF/xacro and args, SRDF, joint_limits.yaml
 * velocities), the SRDF checked against the URDF, and the end effector chosen by the one rule below.
 * Everything runs in the backend (`robot.expandXacro`, `robot.moveitConfig`, `robot.readSrdf`).
 */
import { rmSync } from "node:fs";
import { basename, dirname } from "node:path";
import type { SimClient, SrdfInfo } from "@robwot/sim-client";
import type { GenerateOptions } from "./commands/generate-options.js";
import type { ToolShape } from "./commands/pose-options.js";
import { CliError } from "./errors.js";

export interface RosInput {
  /** the file the user named (a URDF, a xacro, or the MoveIt config's robot file) */
  source: string;
  /** the URDF to load: `source`, or its expansion in a temporary folder */
  urdf: string;
  packageRoots: Record<string, string>;
  srdf?: string;
  /** the end effector: `--ee`, else the SRDF's (see `srdfEndEffector`), else the backend's default */
  ee?: string;
  group?: string;
  /** the start pose: the SRDF's group state named `home` (see `srdfHome`) */
  home?: { joints: Record<string, number>; from: string };
  /** recorded in twin.json: the xacro file's name and its arguments */
  xacro?: { file: string; args: Record<string, string> };
  /** the temporary folder of the expansion, if any (the caller removes it, or keeps it for an error) */
  expandedDir?: string;
  /** `--limits`: the joint_limits.yaml's name and the velocity and position limits it put into the URDF */
  limits?: { file: string; velocities: Record<string, number>; accelerations: Record<string, number>; jerks?: Record<string, number>; positions?: Record<string, [number, number]> };
  /** joint -> acceleration limit (rad/s^2 or m/s^2) of a MoveIt config's or `--limits`' joint_limits.yaml */
  accelerations?: Record<string, number>;
  /** joint -> jerk limit (rad/s^3 or m/s^3) of that joint_limits.yaml (`max_jerk`): every motion jerk-limited */
  jerks?: Record<string, number>;
  /** `--tcp` / `--tool-mesh`: the flange the tool is mounted on, the TCP offset and the mesh's file name */
  tool?: { flange: string; tcp: number[]; mesh?: string; shape?: ToolShape };
  /** the temporary folder of the URDF with the tool (the caller removes it) */
  toolDir?: string;
  /** `robot.readSrdf`'s warnings: SRDF entries naming a link or joint the robot lacks, skipped as MoveIt does */
  srdfWarnings?: string[];
}

const definedStrings = (roots: Record<string, string | undefined>): Record<string, string> =>
  Object.fromEntries(Object.entries(roots).filter((e): e is [string, string] => e[1] !== undefined));

/**
 * The end effector an SRDF names. With `--group G`: the `<end_effector>` whose `parent_group` is G, else
 * the tip of G's last `<chain>`. Without: the first `<end_effector>` of the file. Undefined when the SRDF
 * names none (the backend's default then: the tip of the longest chain, fixed tips included).
 */
export function srdfEndEffector(info: SrdfInfo, group: string | undefined): string | undefined {
  if (group !== undefined) {
    const g = info.groups.find((x) => x.name === group);
    if (!g) {
      throw new CliError(`--group ${group}: no such planning group in the SRDF (groups: ${info.groups.map((x) => x.name).join(", ") || "none"})`);
    }
    return info.endEffectors.find((e) => e.parentGroup === group)?.parentLink ?? g.chains.at(-1)?.tip;
  }
  return info.endEffectors[0]?.parentLink;
}

/** The group states taken as the twin's start pose, in this order of names (MoveIt setups name it so). */
export const HOME_STATES = ["home"] as const;

/**
 * The SRDF's `home` group state: of `--group` G when given, else of the end effector's group, else the
 * first state named `home`. Undefined when the SRDF has none (the twin then starts at all joints 0).
 */
export function srdfHome(info: SrdfInfo, group: string | undefined): RosInput["home"] {
  const eeGroup = info.endEffectors[0]?.parentGroup;
  const homes = info.groupStates.filter((s) => (HOME_STATES as readonly string[]).includes(s.name));
  const state = homes.find((s) => s.group === (group ?? eeGroup)) ?? (group === undefined ? homes[0] : undefined);
  if (!state) return undefined;
  const joints = Object.fromEntries(Object.entries(state.joints).filter((e): e is [string, number] => e[1] !== undefined));
  return { joints, from: `SRDF group_state "${state.name}" of group "${state.group}"` };
}

/** `--limits FILE` read: its name, velocities and accelerations, and the jerks and positions it gives. */
async function limitsFile(sim: SimClient, file: string): Promise<NonNullable<RosInput["limits"]>> {
  const read = await sim.jointLimits({ file });
  const positions = definedRanges(read.positionLimits);
  const jerks = definedNumbers(read.jerkLimits);
  return {
    file: basename(file),
    velocities: definedNumbers(read.velocityLimits),
    accelerations: definedNumbers(read.accelerationLimits),
    ...(Object.keys(jerks).length > 0 ? { jerks } : {}),
    ...(Object.keys(positions).length > 0 ? { positions } : {}),
  };
}

/** Resolves the robot's files; on failure removes what it created. */
export async function prepareRosInput(opts: GenerateOptions, sim: SimClient, source: string): Promise<RosInput> {
  let packageRoots = opts.packageRoots;
  let srdf = opts.srdf;
  let xacroArgs = opts.xacroArgs;
  let velocityLimits: Record<string, number> = {};
  let positionLimits: Record<string, [number, number]> = {};
  let accelerations: Record<string, number> = {};
  let jerks: Record<string, number> = {};
  let limitsRecord: RosInput["limits"];
  if (opts.moveitConfig !== undefined) {
    const config = await sim.moveitConfig({ dir: opts.moveitConfig, packageRoots });
    source = config.urdf;
    packageRoots = definedStrings(config.packageRoots);
    srdf ??= config.srdf;
    // a MoveIt config's robot file goes through xacro even when it is a plain URDF: the velocity limits
    // are written into the expansion, never into the user's file
    xacroArgs = { ...definedStrings(config.xacroArgs), ...(opts.xacroArgs ?? {}) };
    velocityLimits = definedNumbers(config.velocityLimits);
    positionLimits = definedRanges(config.positionLimits);
    accelerations = definedNumbers(config.accelerationLimits);
    jerks = definedNumbers(config.jerkLimits);
  }
  if (opts.limits !== undefined) {
    // a joint_limits.yaml for any robot: its velocities and positions go into the URDF through the same expansion
    limitsRecord = await limitsFile(sim, opts.limits);
    velocityLimits = { ...velocityLimits, ...limitsRecord.velocities };
    positionLimits = { ...positionLimits, ...(limitsRecord.positions ?? {}) };
    accelerations = { ...accelerations, ...limitsRecord.accelerations };
    jerks = { ...jerks, ...(limitsRecord.jerks ?? {}) };
    xacroArgs ??= {};
  }
  const input: RosInput = { source, urdf: source, packageRoots, ...(srdf !== undefined ? { srdf } : {}), ...(limitsRecord ? { limits: limitsRecord } : {}) };
  // a URDF has no acceleration limits: they go to twin.json and robot.load
  if (Object.keys(accelerations).length > 0) input.accelerations = accelerations;
  if (Object.keys(jerks).length > 0) input.jerks = jerks;
  if (xacroArgs !== undefined) {
    const expanded = await sim.expandXacro({ xacro: source, args: xacroArgs, packageRoots, velocityLimits, positionLimits });
    input.urdf = expanded.urdf;
    input.expandedDir = dirname(expanded.urdf);
    input.packageRoots = definedStrings(expanded.packageRoots);
    // a plain URDF goes through the expansion only for its velocity limits: it was no xacro
    if (source.endsWith(".xacro") || opts.moveitConfig !== undefined) input.xacro = { file: basename(source), args: xacroArgs };
  }
  try {
    const info = srdf !== undefined ? await sim.readSrdf({ srdf, urdf: input.urdf }) : undefined;
    if (info !== undefined && info.warnings.length > 0) input.srdfWarnings = info.warnings;
    const ee = opts.ee ?? (info ? srdfEndEffector(info, opts.group) : undefined);
    if (ee !== undefined) input.ee = ee;
    if (opts.group !== undefined) input.group = opts.group;
    const home = info ? srdfHome(info, opts.group) : undefined;
    if (home !== undefined) input.home = home;
    if (opts.tcp !== undefined || opts.toolMesh !== undefined || opts.toolShape !== undefined) {
      // the tool goes on the end effector chosen above (--ee, the SRDF's, else the backend's default); the
      // TCP link it adds is then the end effector
      const [x = 0, y = 0, z = 0, roll = 0, pitch = 0, yaw = 0] = opts.tcp ?? [];
      const tcp: [number, number, number, number, number, number] = [x, y, z, roll, pitch, yaw];
      const attached = await sim.attachTool({
        urdf: input.urdf,
        packageRoots: input.packageRoots,
        tcp,
        ...(input.ee !== undefined ? { eeLink: input.ee } : {}),
        ...(opts.toolMesh !== undefined ? { mesh: opts.toolMesh } : {}),
        ...(opts.toolShape !== undefined ? { shape: opts.toolShape } : {}),
      });
      input.toolDir = dirname(attached.urdf);
      input.urdf = attached.urdf;
      input.packageRoots = definedStrings(attached.packageRoots);
      input.ee = attached.tcpLink;
      input.tool = {
        flange: attached.flange,
        tcp,
        ...(opts.toolMesh !== undefined ? { mesh: basename(opts.toolMesh) } : {}),
        ...(opts.toolShape !== undefined ? { shape: opts.toolShape } : {}),
      };
    }
    return input;
  } catch (err) {
    if (input.expandedDir !== undefined) rmSync(input.expandedDir, { recursive: true, force: true });
    if (input.toolDir !== undefined) rmSync(input.toolDir, { recursive: true, force: true });
    throw err;
  }
}

function definedRanges(values: Record<string, number[] | undefined>): Record<string, [number, number]> {
  return Object.fromEntries(
    Object.entries(values).flatMap(([k, v]) => (v !== undefined && v.length === 2 ? [[k, [v[0], v[1]] as [number, number]]] : [])),
  );
}

function definedNumbers(values: Record<string, number | undefined>): Record<string, number> {
  return Object.fromEntries(Object.entries(values).filter((e): e is [string, number] => e[1] !== undefined));
}
