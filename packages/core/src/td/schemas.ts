/** JSON data schemas of RobWoT's affordances (Contract 3). Units: "rad", "m", "s", "m/s". */
import { VALUE_SCHEMAS } from "../backend-contract.js";
import type { Bounds, JointSpec } from "../types.js";
import type { DataSchema } from "./types.js";

export const UNIT_RAD = "rad";
export const UNIT_M = "m";
export const UNIT_S = "s";
export const UNIT_KG = "kg";
export const UNIT_M_PER_S = "m/s";

export function jointUnit(joint: JointSpec): string {
  return joint.type === "prismatic" ? UNIT_M : UNIT_RAD;
}

/** One number per controllable joint, all required, limits from the URDF. */
export function jointsSchema(joints: JointSpec[], description: string): DataSchema {
  const properties: Record<string, DataSchema> = {};
  for (const j of joints) {
    properties[j.name] = {
      type: "number",
      title: j.name,
      description: `${j.type} joint position`,
      unit: jointUnit(j),
      minimum: j.lower,
      maximum: j.upper,
    };
  }
  return {
    type: "object",
    description,
    properties,
    required: joints.map((j) => j.name),
    additionalProperties: false,
  };
}

function coordinate(axis: "x" | "y" | "z", bounds: Bounds | null): DataSchema {
  const i = axis === "x" ? 0 : axis === "y" ? 1 : 2;
  const s: DataSchema = { type: "number", unit: UNIT_M, description: `${axis} coordinate of the end-effector link frame` };
  if (bounds) {
    s.minimum = bounds.min[i];
    s.maximum = bounds.max[i];
  }
  return s;
}

export function quaternionSchema(description: string): DataSchema {
  const c = (): DataSchema => ({ type: "number", minimum: -1, maximum: 1 });
  return {
    type: "object",
    description,
    properties: { x: c(), y: c(), z: c(), w: c() },
    required: ["x", "y", "z", "w"],
    additionalProperties: false,
  };
}

export function xyzSchema(description: string, bounds: Bounds | null = null): DataSchema {
  return {
    type: "object",
    description,
    properties: { x: coordinate("x", bounds), y: coordinate("y", bounds), z: coordinate("z", bounds) },
    required: ["x", "y", "z"],
    additionalProperties: false,
  };
}

/** Quaternions of a smaller norm count as zero: no orientation (the backend contract's `QuatXyzw`). */
export const MIN_QUATERNION_NORM = VALUE_SCHEMAS.QuatXyzw["x-minNorm"];

/** Slowest speed fraction accepted (the backend contract's `Speed`). */
export const MIN_SPEED = VALUE_SCHEMAS.Speed.minimum;

export const speedSchema = (): DataSchema => ({
  type: "number",
  description: `Fraction of the URDF joint velocity limits (${MIN_SPEED} <= speed <= ${VALUE_SCHEMAS.Speed.maximum})`,
  minimum: MIN_SPEED,
  maximum: VALUE_SCHEMAS.Speed.maximum,
  default: VALUE_SCHEMAS.Speed.default,
});

/** Cartesian pose: x, y, z required (bounded by the collision-free points), orientation optional. */
export function cartesianSchema(bounds: Bounds | null, withSpeed: boolean, description: string): DataSchema {
  const s = xyzSchema(description, bounds);
  s.properties = {
    ...s.properties,
    orientation: quaternionSchema("End-effector orientation quaternion {x,y,z,w}; any orientation if absent"),
  };
  if (withSpeed) {
    s.properties.speed = speedSchema();
    s.properties.motion = motionSchema();
    s.properties.via = xyzSchema("motion circ: a point of the arc (m), in the frame of x, y, z", bounds);
  }
  return s;
}

/** validateProgram's input: steps, each a joint target (PTP) or a Cartesian one reached by `motion`. */
export function programInputSchema(joints: JointSpec[], bounds: Bounds | null): DataSchema {
  const xyz = xyzSchema("", bounds).properties ?? {};
  return {
    type: "object",
    description: "A program: its steps in order, each from where the previous one ends",
    properties: {
      steps: {
        type: "array",
        minItems: 1,
        maxItems: VALUE_SCHEMAS.ProgramSteps.maxItems,
        items: {
          type: "object",
          description: "joints (PTP to a joint target), or x, y, z (+ orientation) reached by motion (via for circ), or motion grip / release alone (the gripper acts where the step before ends); speed a fraction of the velocity limits",
          properties: {
            motion: {
              ...motionSchema(),
              enum: ["ptp", "lin", "circ", "grip", "release"],
              description: `${String(motionSchema().description)}; grip: the gripper closes (for its time) where the step before ends, and the object it catches is checked with the robot in every later step; release: it opens, the object let go and settled (a twin generated with --gripper)`,
            },
            joints: jointsSchema(joints, "Target position of every controllable joint (a PTP step)"),
            ...xyz,
            orientation: quaternionSchema("End-effector orientation quaternion {x,y,z,w}; any orientation (PTP) or kept (LIN, CIRC) if absent"),
            via: xyzSchema("circ: a point of the arc (m)", bounds),
            speed: speedSchema(),
            acceleration: {
              type: "number",
              minimum: VALUE_SCHEMAS.Acceleration.minimum,
              maximum: VALUE_SCHEMAS.Acceleration.maximum,
              default: VALUE_SCHEMAS.Acceleration.default,
              description: `Fraction of the joint acceleration limits (joint_limits.yaml; else each joint reaches its velocity limit in ${VALUE_SCHEMAS.Acceleration["x-accelerationTime"]} s) and of the TCP's acceleration along a LIN or CIRC (${VALUE_SCHEMAS.Acceleration["x-tcpAcceleration"]} m/s^2)`,
            },
            tcpSpeed: {
              type: "number",
              unit: "m/s",
              minimum: VALUE_SCHEMAS.TcpSpeed.minimum,
              maximum: VALUE_SCHEMAS.TcpSpeed.maximum,
              default: VALUE_SCHEMAS.TcpSpeed.default,
              description: "lin, circ: the TCP's speed along the line or arc; a step whose joints cannot keep it within their velocity limits x speed (near a singularity) is refused",
            },
            blend: {
              type: "number",
              unit: "m",
              minimum: VALUE_SCHEMAS.BlendRadius.minimum,
              maximum: VALUE_SCHEMAS.BlendRadius.maximum,
              default: VALUE_SCHEMAS.BlendRadius.default,
              description: "within this distance of the TCP from where the step ends, the motion may leave the path to go on into the next step without stopping (0: it stops; a detour and the last step always stop)",
            },
          },
          additionalProperties: false,
        },
      },
    },
    required: ["steps"],
    additionalProperties: false,
  };
}

/** runProgram's answer: the motion's outcome, the step it ended in, the plan's cycle time, the relay's steps. */
export function programRunResultSchema(joints: JointSpec[]): DataSchema {
  const motion = moveResultSchema(joints);
  return {
    type: "object",
    description: "Result of a program run: the motion's end, the step it ended in and, with a relay, the physical robot's answer per step",
    properties: {
      status: motion.properties?.status ?? {},
      step: { type: "integer", minimum: 0, description: "index of the step the run ended in (the last one when reached)" },
      joints: motion.properties?.joints ?? {},
      position: motion.properties?.position ?? {},
      orientation: motion.properties?.orientation ?? {},
      duration: { type: "number", unit: UNIT_S, minimum: 0, description: "simulated time run" },
      cycleTime: { type: "number", unit: UNIT_S, minimum: 0, description: "the planned cycle time (validateProgram's)" },
      relay: {
        type: "object",
        description: "with --relay: the physical robot ran the steps one after the other, after the simulation had run them all",
        properties: {
          ok: { type: "boolean" },
          steps: {
            type: "array",
            items: {
              type: "object",
              properties: { step: { type: "integer", minimum: 0 }, ok: { type: "boolean" }, status: { type: "integer" }, error: { type: "string" } },
              required: ["step", "ok"],
            },
          },
          error: { type: "string" },
        },
        required: ["ok", "steps"],
      },
    },
    required: ["status", "step", "joints", "position", "orientation", "duration", "cycleTime"],
  };
}

/** validateProgram's answer. */
export function programReportSchema(): DataSchema {
  return {
    type: "object",
    properties: {
      valid: { type: "boolean" },
      firstFailingStep: { type: "integer", minimum: 0, description: "index of the first refused step; absent when every step passes" },
      cycleTime: { type: "number", unit: UNIT_S, minimum: 0, description: "the sum of the steps' durations: what running them one after the other takes at real time" },
      steps: {
        type: "array",
        items: {
          type: "object",
          properties: {
            step: { type: "integer", minimum: 0 },
            ok: { type: "boolean" },
            reasons: { type: "array", items: { type: "string" } },
            duration: { type: "number", unit: UNIT_S, minimum: 0 },
            planned: { type: "string", enum: ["straight", "detour", "lin", "circ", "grip", "release"] },
            holding: { type: "string", description: "a grip or release step: the object the gripper holds after it (absent: none)" },
            blended: { type: "boolean", description: "the motion goes on into the next step without stopping" },
          },
          required: ["step", "ok", "reasons", "duration"],
        },
      },
      trajectory: {
        type: "object",
        description: "the joint states the steps pass, sampled at rate",
        properties: {
          rate: { type: "number", unit: "Hz" },
          names: { type: "array", items: { type: "string" } },
          positions: { type: "array", items: { type: "array", items: { type: "number" } } },
        },
      },
    },
    required: ["valid", "cycleTime", "steps", "trajectory"],
  };
}

/** How a Cartesian target is reached: the backend contract's `motion` of `robot.plan` / `robot.move`. */
export const motionSchema = (): DataSchema => ({
  type: "string",
  enum: ["ptp", "lin", "circ"],
  default: "ptp",
  description:
    "ptp: joint interpolation from the current joints (a detour when the straight one collides); lin: the end effector on the straight line to the target, its orientation turned on the way (kept when absent), within 0.5 mm of the line, the joints tracked on their branch, refused where it ends (a joint limit, a singularity, the reach, a flip) naming the first cause along the line; circ: the same on the arc of the circle through the current position, via and the target",
});

export function jointTargetSchema(joints: JointSpec[], description: string): DataSchema {
  return {
    type: "object",
    description,
    properties: {
      joints: jointsSchema(joints, "Target position of every controllable joint"),
      speed: speedSchema(),
    },
    required: ["joints"],
    additionalProperties: false,
  };
}

const contactSide = (): DataSchema => ({
  type: "object",
  properties: {
    body: { type: "string", description: "robot id or obstacle name" },
    link: { type: "string", description: "link name; absent for an obstacle and a robot's base" },
  },
  required: ["body"],
});

export function contactSchema(): DataSchema {
  return {
    type: "object",
    properties: {
      a: contactSide(),
      b: contactSide(),
      depth: { type: "number", unit: UNIT_M, minimum: 0 },
      position: vec3Schema("contact point"),
    },
    required: ["a", "b", "depth", "position"],
  };
}

export function vec3Schema(description: string, unit: string | null = UNIT_M): DataSchema {
  const items: DataSchema = unit === null ? { type: "number" } : { type: "number", unit };
  return { type: "array", description, items, minItems: 3, maxItems: 3 };
}

export function moveResultSchema(joints: JointSpec[]): DataSchema {
  const jointsOut = jointsSchema(joints, "Joint positions at the end of the motion");
  return {
    type: "object",
    description: "Result of a motion",
    properties: {
      status: { type: "string", enum: ["reached", "stopped", "collision"] },
      joints: jointsOut,
      position: xyzSchema("End-effector position at the end of the motion"),
      orientation: quaternionSchema("End-effector orientation at the end of the motion"),
      duration: { type: "number", unit: UNIT_S, minimum: 0 },
      positionError: { type: "number", unit: UNIT_M, minimum: 0, description: "Cartesian moves: distance to the target" },
      path: {
        type: "string",
        enum: ["straight", "detour", "lin", "circ"],
        description: "straight joint-space path, or a detour planned around obstacles (RRT-Connect) when no straight one was free",
      },
    },
    required: ["status", "joints", "position", "orientation", "duration"],
  };
}

export function validationReportSchema(): DataSchema {
  const ok = { type: "boolean" } as const;
  return {
    type: "object",
    description:
      "The simulation decides: valid = reachable by IK within the joint limits and a collision-free path (with clearance) in the current scene. " +
      "The static checks on the linked files (insideWorkspace, pointCloud, reachability) are reported in checks and notes, never a veto.",
    properties: {
      valid: { type: "boolean", description: "the simulation-in-the-loop verdict" },
      reasons: { type: "array", items: { type: "string" }, description: "why the target is refused (empty when valid)" },
      notes: { type: "array", items: { type: "string" }, description: "static checks that disagree with the verdict" },
      checks: {
        type: "object",
        properties: {
          limits: { type: "object", properties: { ok } },
          insideWorkspace: { type: "object", properties: { ok }, description: "inside workspace.stl" },
          pointCloud: {
            type: "object",
            description:
              "ok when a collision-free workspace.csv sample lies within maxGap of the target (the position is reachable collision-free); " +
              "score (reported, not deciding) is the share of colliding samples among the k nearest",
            properties: {
              score: { type: "number", minimum: 0, maximum: 1 },
              k: { type: "integer" },
              nearestFree: { type: "number", unit: UNIT_M, description: "distance to the nearest collision-free sample; -1 when there is none" },
              maxGap: { type: "number", unit: UNIT_M },
              ok,
            },
          },
          reachability: {
            type: "object",
            description:
              "the target's voxel in the reachability map (reachability.csv): ok when a collision-free sample ends in it; " +
              "index = share of the 64 approach directions reached there collision-free",
            properties: {
              ok,
              index: { type: "number", minimum: 0, maximum: 1 },
              samples: { type: "integer", minimum: 0 },
              free: { type: "integer", minimum: 0 },
              voxel: { type: "number", unit: UNIT_M, description: "voxel side" },
            },
          },
          ik: {
            type: "object",
            properties: {
              ok,
              positionError: { type: "number", unit: UNIT_M },
              solutions: { type: "integer", minimum: 1, description: "IK solutions tried until one had a collision-free path" },
            },
          },
          path: {
            type: "object",
            properties: {
              ok,
              planned: { type: "string", enum: ["straight", "detour", "lin", "circ"], description: "a detour is planned when no straight path is free; lin: the end effector on the straight line (motion lin)" },
              detour: {
                type: "string",
                enum: ["found", "not found", "not searched"],
                description: "when the straight path collides: a detour found, none found within the search's budget, or none searched (the target itself collides)",
              },
              clearance: { type: "number", unit: UNIT_M, description: "kept to other bodies along the path (the twin's --clearance)" },
              contacts: { type: "array", items: contactSchema() },
            },
          },
        },
      },
    },
    required: ["valid", "reasons", "checks"],
  };
}

/** `stop`'s answer: both outcomes, the simulation's and (with `--relay`) the physical robot's. Closed. */
export function stopResultSchema(): DataSchema {
  const error = { type: "string", description: "why this part failed" } as const;
  return {
    type: "object",
    description: "A stop is never refused: each part reports its own outcome",
    properties: {
      stopped: { type: "boolean", description: "a move was pending, or the simulation or the physical robot stopped one" },
      simulation: {
        type: "object",
        description: "the simulation's stop (fails when the backend is down or does not answer within the stop deadline)",
        properties: { ok: { type: "boolean" }, error },
        required: ["ok"],
        additionalProperties: false,
      },
      physical: {
        type: "object",
        description: "only with --relay: the physical robot's stop, sent at once and retried until it answers or the stop deadline passes",
        properties: { ok: { type: "boolean" }, attempts: { type: "integer", minimum: 0, description: "stop requests sent" }, error },
        required: ["ok", "attempts"],
        additionalProperties: false,
      },
    },
    required: ["stopped", "simulation"],
    additionalProperties: false,
  };
}

export function calibrationResultSchema(): DataSchema {
  return {
    type: "object",
    description: "x_real = scale * rotation * x_virtual + translation",
    properties: {
      scale: { type: "number", exclusiveMinimum: 0 },
      rotation: { type: "array", items: { type: "array", items: { type: "number" }, minItems: 3, maxItems: 3 }, minItems: 3, maxItems: 3, description: "3x3 row-major, det +1" },
      translation: vec3Schema("translation"),
      rms: { type: "number", unit: UNIT_M, minimum: 0, description: "RMS residual over the pairs" },
      pairs: { type: "integer", minimum: 3 },
    },
    required: ["scale", "rotation", "translation", "rms", "pairs"],
  };
}

/** Deep copy of a data schema in which every object schema that names its `properties` is closed
 * (`additionalProperties: false`): what the servient accepts as action input. */
export function closeSchema(schema: unknown): unknown {
  if (Array.isArray(schema)) return schema.map(closeSchema);
  if (schema === null || typeof schema !== "object") return schema;
  const out: Record<string, unknown> = {};
  for (const [k, v] of Object.entries(schema)) out[k] = k === "enum" || k === "const" || k === "default" ? v : closeSchema(v);
  if (out.properties !== undefined && out.additionalProperties === undefined) out.additionalProperties = false;
  return out;
}

/** A backend contact as the TD states it: a side without a link (obstacle, robot base) omits `link`. */
export function tdContact<C extends { a: { body: string; link: string | null }; b: { body: string; link: string | null } }>(c: C): C {
  const side = (s: { body: string; link: string | null }) => (s.link === null ? { body: s.body } : s);
  return { ...c, a: side(c.a), b: side(c.b) } as C;
}
