/** Realistic robot models for tests (kuka iiwa-like limits from pybullet_data's kuka_iiwa/model.urdf). */
import { TWIN_FILES } from "../twin-layout.js";
import type { JointSpec, RobotModelLike, WorkspaceSummary } from "../types.js";

const IIWA_LIMITS = [2.96, 2.09, 2.96, 2.09, 2.96, 2.09, 3.05];

/** 7 revolute joints + a prismatic lift + a continuous wrist roll + a fixed and a mimic finger joint. */
export function kukaLikeModel(): RobotModelLike {
  const joints: JointSpec[] = IIWA_LIMITS.map((lim, i) => ({
    name: `lbr_iiwa_joint_${i + 1}`,
    type: "revolute",
    lower: -lim,
    upper: lim,
    velocity: 10,
    effort: 300,
    parent: `lbr_iiwa_link_${i}`,
    child: `lbr_iiwa_link_${i + 1}`,
  }));
  joints.push(
    { name: "lift", type: "prismatic", lower: 0, upper: 0.25, velocity: 0.2, effort: 500 },
    { name: "tool_roll", type: "continuous", lower: -Math.PI, upper: Math.PI, velocity: 6, effort: 10 },
    { name: "tool_fixed", type: "fixed", lower: 0, upper: 0, velocity: 0, effort: 0 },
    { name: "finger_left", type: "prismatic", lower: 0, upper: 0.04, velocity: 0.1, effort: 20 },
    { name: "finger_right", type: "prismatic", lower: 0, upper: 0.04, velocity: 0.1, effort: 20, mimic: { joint: "finger_left", multiplier: 1, offset: 0 } },
  );
  return {
    id: "lbr_iiwa",
    name: "lbr_iiwa",
    eeLink: "lbr_iiwa_link_7",
    joints,
    controllable: [...joints.filter((j) => j.type !== "fixed" && !j.mimic).map((j) => j.name)],
    basePosition: [0, 0, 0],
    baseOrientation: [0, 0, 0, 1],
  };
}

export function summaryFixture(): WorkspaceSummary {
  return {
    samples: 80000,
    collisionFree: 71234,
    bounds: { min: [-1.1, -1.05, -0.3], max: [1.1, 1.08, 1.31] },
    reachBounds: { min: [-1.2, -1.2, -0.95], max: [1.2, 1.2, 1.36] },
    alpha: 0.12,
    method: "alpha-shape",
    volume: 4.2,
    seed: 1,
    reachability: { file: TWIN_FILES.reachability, voxel: 0.16, voxels: 900, directions: 64, approachAxis: "z" },
    timings: { sample: 0.1, collide: 3.2, alpha: 1.1, write: 0.2 },
    versions: { robwot: "0.1.0" },
  };
}
