/**
 * The ONLY place where the URDF/ROS world frame meets three.js's frame.
 *
 *   URDF / ROS / simulation (Z up)          three.js (Y up)
 *
 *          Z                                        Y
 *          |   X                                    |
 *          | /                                      |
 *   Y -----.                                        .----- X
 *                                                  /
 *                                                 Z
 *
 * Both frames are right-handed. Everything the viewer draws from twin data (robot, obstacles, point
 * cloud, workspace mesh, markers) is added, in URDF world coordinates (metres), under one root group
 * that is rotated by -90 degrees about X. That rotation maps
 *   URDF +X -> three +X,   URDF +Y -> three -Z,   URDF +Z -> three +Y.
 * Code outside this module never swaps axes: it builds in URDF coordinates and adds to `worldRoot`, and
 * asks `urdfToThree` when it needs a three.js position (camera placement).
 */
import { Euler, Group, Quaternion, Vector3 } from "three";

export type Vec3 = readonly [number, number, number];
/** Quaternion in the project's convention: [x, y, z, w]. */
export type QuatXyzw = readonly [number, number, number, number];

export function createWorldRoot(): Group {
  const root = new Group();
  root.name = "urdf-world (Z up)";
  root.rotation.set(-Math.PI / 2, 0, 0);
  return root;
}

/** A point given in the URDF world frame, expressed in three.js's frame. */
export function urdfToThree(p: Vec3): Vector3 {
  return new Vector3(p[0], p[2], -p[1]);
}

/** URDF roll-pitch-yaw (fixed axes X, then Y, then Z) as a quaternion in the same (URDF) frame. */
export function rpyToQuaternion(rpy: Vec3): Quaternion {
  return new Quaternion().setFromEuler(new Euler(rpy[0], rpy[1], rpy[2], "ZYX"));
}

export function xyzwToQuaternion(q: QuatXyzw): Quaternion {
  return new Quaternion(q[0], q[1], q[2], q[3]).normalize();
}
