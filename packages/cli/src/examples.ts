/**
 * Example robots usable by name instead of a URDF path: URDFs shipped in PyBullet's `pybullet_data`
 * (located through the backend's `ping`), plus small robots bundled with the CLI under `robots/`.
 */
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

export interface ExampleRobot {
  name: string;
  /** Where the file lives: inside pybullet_data, or in this package's `robots/` folder. */
  source: "pybullet_data" | "bundled";
  /** Path relative to the source folder. */
  file: string;
  description: string;
}

export const EXAMPLE_ROBOTS: readonly ExampleRobot[] = [
  { name: "kuka_iiwa", source: "pybullet_data", file: "kuka_iiwa/model.urdf", description: "KUKA LBR iiwa 7 R800, 7 DoF" },
  { name: "franka_panda", source: "pybullet_data", file: "franka_panda/panda.urdf", description: "Franka Emika Panda with hand, 7 DoF + 2 fingers" },
  { name: "xarm6", source: "pybullet_data", file: "xarm/xarm6_robot.urdf", description: "UFACTORY xArm 6, 6 DoF" },
  { name: "xarm6_gripper", source: "pybullet_data", file: "xarm/xarm6_with_gripper.urdf", description: "xArm 6 with gripper (mimic joints)" },
  { name: "ur3", source: "bundled", file: "ur3.urdf", description: "UR3 kinematics with primitive geometry, 6 DoF" },
  { name: "two_joint", source: "pybullet_data", file: "TwoJointRobot_wo_fixedJoints.urdf", description: "planar 2-joint arm (flat workspace: a 2 mm slab around its plane)" },
];

export const EXAMPLE_NAMES: readonly string[] = EXAMPLE_ROBOTS.map((r) => r.name);

/** The folder holding the bundled robots (`packages/cli/robots`), from `dist/` or `src/`. */
export function bundledRobotsDir(): string {
  return join(dirname(fileURLToPath(import.meta.url)), "..", "robots");
}

export function findExample(name: string): ExampleRobot | undefined {
  return EXAMPLE_ROBOTS.find((r) => r.name === name);
}

/** A bare word (no path separator, no `.urdf`/`.xml` suffix) is meant as an example name. */
export function looksLikeExampleName(arg: string): boolean {
  return !/[\\/]/.test(arg) && !/\.(urdf|xml)$/i.test(arg);
}

/** Absolute URDF path of an example; `pybulletData` comes from the backend's `ping`. */
export function exampleUrdfPath(example: ExampleRobot, pybulletData: string): string {
  return example.source === "bundled" ? join(bundledRobotsDir(), example.file) : join(pybulletData, example.file);
}

export function exampleHelp(): string {
  const w = Math.max(...EXAMPLE_ROBOTS.map((r) => r.name.length));
  return EXAMPLE_ROBOTS.map((r) => `  ${r.name.padEnd(w)}  ${r.description}`).join("\n");
}
