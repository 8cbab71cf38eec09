/**
 * A move's or a program step's input, parsed once into what the backend is asked (a joint vector, or a
 * pose target in the simulation's frame) and what the physical robot is sent (its relay leg, in the
 * frame of the TD). The schema has checked the joint names and bounded the numbers already; what it cannot
 * say is checked here (a speed in range, a quaternion of usable norm, which fields go together in a step),
 * and nothing after this re-checks it. The relay command of a move action is built here and nowhere else.
 */
import type { ProgramSteps } from "@robwot/sim-client";
import { MIN_QUATERNION_NORM, MIN_SPEED, type Quaternion, vec, type Vec3 } from "@robwot/core";
import { badInput } from "./errors.js";
import type { Twin } from "./twin.js";
import { poseTarget, type PoseTarget } from "./validation.js";

export interface JointInput {
  /** every controllable joint, no other (the TD's schema) */
  joints: Record<string, number>;
  speed?: number;
}

export interface CartesianInput {
  x: number;
  y: number;
  z: number;
  orientation?: Quaternion;
  speed?: number;
  /** "ptp" (default), "lin" or "circ" (the schema allows no other) */
  motion?: string;
  /** circ: a point of the arc, in the frame of x, y, z */
  via?: { x: number; y: number; z: number };
}

export interface ProgramInput {
  steps: (Partial<CartesianInput> & { joints?: Record<string, number>; acceleration?: number; tcpSpeed?: number; blend?: number })[];
}

/** One command to the physical robot: a move action of the twin's TD and its input. */
export interface RelayLeg {
  action: string;
  input: unknown;
}

/** A joint move: the target vector in `model.controllable` order. */
export interface JointMove {
  q: number[];
  speed: number;
}

/** A Cartesian move: the target as the consumer gave it (real frame) and as the backend plans it. */
export interface CartesianMove {
  real: Vec3;
  orientation?: Quaternion;
  target: PoseTarget;
  speed: number;
  /** the physical robot's command for the same target */
  leg: RelayLeg;
}

/** A program: its steps for the backend and, one per step, the physical robot's commands. */
export interface ProgramMove {
  sim: ProgramSteps;
  legs: RelayLeg[];
}

export function speedOf(input: { speed?: unknown }): number {
  const s = input.speed ?? 1;
  if (typeof s !== "number" || !Number.isFinite(s) || s < MIN_SPEED || s > 1) {
    throw badInput(`speed must be a number in [${MIN_SPEED}, 1], got ${JSON.stringify(s)}`, { param: "speed", value: s ?? null });
  }
  return s;
}

/** The position (and the unit quaternion, when given) of a Cartesian input, in the frame of the TD. */
export function cartesianTarget(input: CartesianInput): { real: Vec3; orientation?: Quaternion } {
  for (const k of ["x", "y", "z"] as const) {
    if (typeof input[k] !== "number" || !Number.isFinite(input[k])) {
      throw badInput(`${k} must be a finite number (m), got ${JSON.stringify(input[k])}`, { param: k, value: input[k] ?? null });
    }
  }
  const o = input.orientation;
  if (o !== undefined) {
    const n = Math.hypot(o.x, o.y, o.z, o.w);
    if (![o.x, o.y, o.z, o.w].every((v) => typeof v === "number" && Number.isFinite(v)) || n < MIN_QUATERNION_NORM) {
      throw badInput(`orientation must be a quaternion {x, y, z, w} of norm >= ${MIN_QUATERNION_NORM}`, { param: "orientation", value: o });
    }
    return { real: vec(input), orientation: { x: o.x / n, y: o.y / n, z: o.z / n, w: o.w / n } };
  }
  return { real: vec(input) };
}

/** A joint move of the physical robot to `q`. */
export function jointLeg(twin: Twin, q: readonly number[], speed: number): RelayLeg {
  return { action: "moveToJointPosition", input: { joints: twin.jointsRecord([...q]), speed } };
}

/** A detour's waypoints as joint moves: each leg is a straight joint-space segment the twin checked, as
 * a physical robot's joint move runs it; sent as one command, the target alone would go straight. */
export function detourLegs(twin: Twin, detour: readonly number[][], speed: number): RelayLeg[] {
  return detour.map((q) => jointLeg(twin, q, speed));
}

/** The physical robot's Cartesian move: the target in the frame of the TD; `motion` only when it is not
 *  the move actions' default (PTP). */
function cartesianLeg(input: CartesianInput, t: { real: Vec3; orientation?: Quaternion }, speed: number): RelayLeg {
  const cmd: Record<string, unknown> = { x: t.real[0], y: t.real[1], z: t.real[2], speed };
  if (t.orientation) cmd.orientation = t.orientation;
  if (input.motion === "lin" || input.motion === "circ") cmd.motion = input.motion;
  if (input.via) cmd.via = input.via;
  return { action: "moveToCartesianPosition", input: cmd };
}

export function parseJointMove(twin: Twin, input: JointInput): JointMove {
  return { q: twin.jointsVector(input.joints), speed: speedOf(input) };
}

export function parseCartesianMove(twin: Twin, input: CartesianInput): CartesianMove {
  const t = cartesianTarget(input);
  const speed = speedOf(input);
  const via: Vec3 | undefined = input.via === undefined ? undefined : [input.via.x, input.via.y, input.via.z];
  const target = poseTarget(twin, t.real, t.orientation, input.motion, via);
  return { ...t, target, speed, leg: cartesianLeg(input, t, speed) };
}

/** A program's steps for the backend (joint vectors; Cartesian in the simulation's frame) and as the
 * physical robot's move actions take them (in the frame of the TD). */
export function parseProgram(twin: Twin, input: ProgramInput): ProgramMove {
  const legs: RelayLeg[] = [];
  const sim = input.steps.map((step, k) => {
    const speed = speedOf(step);
    // acceleration and tcpSpeed: the schema bounds them (the contract's Acceleration and TcpSpeed)
    const timing = {
      ...(step.acceleration !== undefined ? { acceleration: step.acceleration } : {}),
      ...(step.tcpSpeed !== undefined ? { tcpSpeed: step.tcpSpeed } : {}),
      ...(step.blend !== undefined ? { blend: step.blend } : {}),
    };
    const hasXyz = step.x !== undefined || step.y !== undefined || step.z !== undefined;
    if (step.motion === "grip" || step.motion === "release") {
      // the gripper acts where the step before ends; the physical robot's gripClose / gripOpen when relayed
      if (step.joints !== undefined || hasXyz || step.orientation !== undefined || step.via !== undefined) {
        throw badInput(`steps[${k}]: a ${step.motion} step has no target: the gripper acts where the step before ends`, { param: `steps[${k}]` });
      }
      legs.push({ action: step.motion === "grip" ? "gripClose" : "gripOpen", input: {} });
      return { motion: step.motion };
    }
    if ((step.joints !== undefined) === hasXyz) {
      throw badInput(`steps[${k}]: give joints (a PTP step) or x, y, z, not ${hasXyz ? "both" : "neither"}`, { param: `steps[${k}]` });
    }
    if (step.joints !== undefined) {
      if (step.motion !== undefined && step.motion !== "ptp") throw badInput(`steps[${k}]: a joint target is a PTP step, not ${step.motion}`, { param: `steps[${k}].motion` });
      const q = twin.jointsVector(step.joints);
      legs.push(jointLeg(twin, q, speed));
      return { target: q, speed, ...timing };
    }
    if ((step.via !== undefined) !== (step.motion === "circ")) throw badInput(`steps[${k}]: via goes with motion circ, and only with it`, { param: `steps[${k}].via` });
    const move = parseCartesianMove(twin, step as CartesianInput);
    legs.push(move.leg);
    return { ...move.target, speed, ...timing };
  });
  return { sim: sim as ProgramSteps, legs };
}
