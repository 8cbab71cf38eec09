/** The affordances of a RobWoT twin (Contract 3), without forms. */
import { MAX_CALIBRATION_COORDINATE as C } from "../calibration.js";
import type { Bounds, JointSpec } from "../types.js";
import { moveObjectSchema, moveObstacleSchema, objectOutputSchema, objectSchema, objectsSchema, obstacleOutputSchema, obstacleSchema, removeObstacleSchema } from "./obstacle-schemas.js";
import {
  calibrationResultSchema,
  cartesianSchema,
  contactSchema,
  jointTargetSchema,
  jointsSchema,
  moveResultSchema,
  programInputSchema,
  programReportSchema,
  programRunResultSchema,
  quaternionSchema,
  stopResultSchema,
  UNIT_M,
  UNIT_S,
  validationReportSchema,
  xyzSchema,
} from "./schemas.js";
import type { ActionAffordance, DataSchema, EventAffordance, PropertyAffordance } from "./types.js";

type NoForms<T> = Omit<T, "forms">;

/** Calibration points lie within MAX_CALIBRATION_COORDINATE (m) of the origin on every axis. */
const CALIBRATION_BOX: Bounds = { min: [-C, -C, -C], max: [C, C, C] };

/** The gripper's state: open, closed or moving (while it opens or closes), the object it holds (null when
 *  none: a oneOf of typed schemas, TD 1.1 having no list of types; a consumer that needs a `type` on every
 *  schema, as wotpy does, cannot read this property). */
export function gripperProperty(): NoForms<PropertyAffordance> {
  return {
    title: "Gripper",
    description: "The gripper: open, closed, or moving while it opens or closes (for its time); the object it holds (null when none: closed on nothing, or open). A held object moves with the TCP and is checked with the robot in every verdict.",
    type: "object",
    properties: {
      state: { type: "string", enum: ["open", "closed", "moving"] },
      holding: { oneOf: [{ type: "string" }, { type: "null" }], description: "the name of the object held, null when none" },
      kind: { type: "string", enum: ["fingers", "suction"] },
      time: { type: "number", unit: UNIT_S, minimum: 0, description: "time an opening or closing takes" },
    },
    required: ["state", "holding", "kind", "time"],
    readOnly: true,
    observable: true,
  };
}

/** gripOpen / gripClose: the real lab's names. */
export function gripperActions(): Record<"gripOpen" | "gripClose", NoForms<ActionAffordance>> {
  const output: DataSchema = {
    type: "object",
    properties: {
      status: { type: "string", enum: ["done", "stopped"] },
      state: { type: "string", enum: ["open", "closed"] },
      holding: { oneOf: [{ type: "string" }, { type: "null" }], description: "the name of the object held, null when none" },
      released: { oneOf: [{ type: "object" }, { type: "null" }], description: "gripOpen: the object let go, where it came to rest; null when none was held" },
    },
    required: ["status", "state", "holding"],
  };
  return {
    gripClose: {
      title: "Close the gripper",
      description: "Closes the gripper (for its time) on the object nearest the TCP within its capture distance, if any, and holds it: it moves with the TCP and every check of the robot includes it (against everything but the hand). Closing on nothing answers holding: null. Busy (409) while the robot moves; a stop ends it before it closes.",
      output,
      safe: false,
      idempotent: true,
    },
    gripOpen: {
      title: "Open the gripper",
      description: "Opens the gripper (for its time); an object held is let go where it is and settles onto what is below it (409 E_OVERLAP, still held, where it cannot be let go).",
      output,
      safe: false,
      idempotent: true,
    },
  };
}

export function propertyAffordances(joints: JointSpec[]): Record<string, NoForms<PropertyAffordance>> {
  // the pose *reading* has no bounds: the twin's own states (its home pose, a pose outside the sampled
  // collision-free points) may lie beyond them, and consumers validate readings against the schema
  const cartesian = xyzSchema("End-effector link frame position (calibrated real frame when a calibration is active)", null);
  cartesian.properties = { ...cartesian.properties, orientation: quaternionSchema("End-effector orientation quaternion") };
  cartesian.required = ["x", "y", "z", "orientation"];
  return {
    getJointPosition: {
      ...jointsSchema(joints, "Current position of every controllable joint"),
      title: "Joint positions",
      readOnly: true,
      observable: true,
    },
    getCartesianPosition: { ...cartesian, title: "End-effector pose", readOnly: true, observable: true },
    motionStatus: motionStatusProperty(joints),
    physicalState: physicalStateProperty(joints),
    calibration: calibrationProperty(),
    objects: {
      ...objectsSchema(),
      title: "Objects",
      description: "Every object of the world (scene file objects and addObject's) where it rests now: name, shape, position (m) and orientation (quaternion [x, y, z, w]) in the world frame, mass (kg), colour",
      readOnly: true,
      observable: true,
    },
  };
}

/** The motion status: idle, moving, stopped or collision, with the last error and the last result. */
function motionStatusProperty(joints: JointSpec[]): NoForms<PropertyAffordance> {
  return {
    title: "Motion status",
    type: "object",
    readOnly: true,
    observable: true,
    properties: {
      state: { type: "string", enum: ["idle", "moving", "stopped", "collision"] },
      lastError: {
        type: "object",
        description: "why the last operation failed; absent when it succeeded",
        properties: { code: { type: "string" }, message: { type: "string" } },
        required: ["code", "message"],
      },
      lastResult: { ...moveResultSchema(joints), description: "result of the last move; absent before the first" },
    },
    required: ["state"],
  };
}

/** What the twin last read from the physical robot it follows, and the safety monitor's state. */
function physicalStateProperty(joints: JointSpec[]): NoForms<PropertyAffordance> {
  return {
    title: "Physical robot state",
    description:
      "What the twin last read from the physical robot it follows (serve --follow): its joints, the end-effector pose by the twin's forward kinematics (in the TD's frame), when they were read and how old they are; following: false when the twin follows none. When the physical robot moves without a twin command, the twin is set to its state (followed counts those readings).",
    type: "object",
    readOnly: true,
    observable: true,
    properties: {
      following: { type: "boolean" },
      source: { type: "string", format: "uri", description: "the physical robot's TD URL" },
      joints: jointsSchema(joints, "the physical robot's joints as last read"),
      position: xyzSchema("end-effector position at those joints (m)"),
      orientation: quaternionSchema("end-effector orientation at those joints"),
      timestamp: { type: "string", format: "date-time", description: "when the joints were read" },
      age: { type: "number", unit: UNIT_S, minimum: 0, description: "time since then" },
      followed: { type: "integer", minimum: 0, description: "readings that set the twin to the physical state (it moved without a twin command)" },
      lastFollowed: { type: "string", format: "date-time" },
      lastError: { type: "string", maxLength: 1024, description: "why the last reading failed (the physical Thing unreachable or late, a field it got wrong); at most 1 KiB" },
      clamped: { type: "object", additionalProperties: { type: "number" }, description: "joints read a little past their limit (what was read); joints shows them at the limit" },
      monitorFault: {
        type: "object",
        description: "present while the safety monitor cannot see the robot (no usable reading for the horizon plus one poll period)",
        properties: {
          code: { type: "string", const: "E_MONITOR_BLIND" },
          since: { type: "string", format: "date-time", description: "the last usable reading (or the start)" },
          detected: { type: "string", format: "date-time" },
          reason: { type: "string" },
          stop: { type: "object", description: "monitor stop: the stop sent for this fault", properties: { state: { type: "string", enum: ["pending", "answered", "failed"] }, error: { type: "string" } } },
        },
      },
      monitorFaults: { type: "integer", minimum: 0, description: "monitor faults so far" },
      skippedPolls: { type: "integer", minimum: 0, description: "polls skipped because the previous request was still unanswered" },
      readingErrors: { type: "integer", minimum: 0, description: "readings that failed" },
      divergence: {
        type: "object",
        description: "while a command is relayed: the physical robot's difference from the simulated motion at the same time since the command",
        properties: { joint: { type: "number", minimum: 0, description: "rad or m: the largest joint difference" }, tcp: { type: "number", unit: UNIT_M, minimum: 0 } },
      },
      maxDivergence: {
        type: "object",
        description: "the largest divergence during the last relayed command, and the bound of the divergence event",
        properties: { joint: { type: "number", minimum: 0 }, tcp: { type: "number", unit: UNIT_M, minimum: 0 }, bound: { type: "number", minimum: 0 } },
      },
    },
    required: ["following"],
  };
}

/** The active virtual-to-real calibration. */
function calibrationProperty(): NoForms<PropertyAffordance> {
  return {
    title: "Calibration",
    description: "Active virtual-to-real calibration (x_real = s·R·x_virtual + t) or {active: false}",
    type: "object",
    readOnly: true,
    properties: {
      active: { type: "boolean" },
      ...calibrationResultSchema().properties,
      withScale: { type: "boolean" },
      createdAt: { type: "string", format: "date-time" },
    },
    required: ["active"],
  };
}

const cartesianInput = (bounds: Bounds | null): DataSchema =>
  cartesianSchema(bounds, true, "Target end-effector position (m) and optional orientation");

export function actionAffordances(joints: JointSpec[], bounds: Bounds | null): Record<string, NoForms<ActionAffordance>> {
  const jointInput = jointTargetSchema(joints, "Target joint positions and optional speed fraction");
  return {
    moveToJointPosition: {
      title: "Move in joint space",
      description: "Validates the target (limits, collision along the path), then moves; completes when the motion ends.",
      input: jointInput,
      output: moveResultSchema(joints),
      safe: false,
      idempotent: false,
    },
    moveToCartesianPosition: {
      title: "Move to a Cartesian target",
      description: "Validates the target (workspace, point cloud, IK, path), then moves; completes when the motion ends.",
      input: cartesianInput(bounds),
      output: moveResultSchema(joints),
      safe: false,
      idempotent: false,
    },
    validateJointPosition: {
      title: "Validate a joint target",
      description: "Simulation-in-the-loop check without moving.",
      input: jointTargetSchema(joints, "Joint target to check"),
      output: validationReportSchema(),
      safe: true,
      idempotent: true,
    },
    validateCartesianPosition: {
      title: "Validate a Cartesian target",
      description: "Inside workspace.stl? point-cloud score, IK reachability, collision-free path; without moving.",
      input: cartesianInput(bounds),
      output: validationReportSchema(),
      safe: true,
      idempotent: true,
    },
    ...programActions(joints, bounds),
    stop: {
      title: "Stop",
      description: "Stops the running motion, if any, in the simulation and (with a relay) on the physical robot at once; never refused.",
      output: stopResultSchema(),
      safe: false,
      idempotent: true,
    },
    calibrate: calibrateAction(),
    addObstacle: { title: "Add an obstacle", input: obstacleSchema(), output: obstacleOutputSchema(), safe: false, idempotent: false },
    moveObstacle: { title: "Move an obstacle", input: moveObstacleSchema(), output: obstacleOutputSchema(), safe: false, idempotent: true },
    removeObstacle: { title: "Remove an obstacle", input: removeObstacleSchema(), output: { type: "object", properties: {} }, safe: false, idempotent: true },
    ...objectActions(),
  };
}

/** Objects: added, moved (let go, then settled onto what is below them) and removed; robots collide with them as with obstacles. */
function objectActions(): Record<"addObject" | "moveObject" | "removeObject", NoForms<ActionAffordance>> {
  const settles = "It settles under gravity onto the obstacles and objects below it, or onto the floor z = 0; placed into a robot, an obstacle or another object it is refused (409 E_OVERLAP naming both).";
  return {
    addObject: { title: "Add an object", description: `Adds an object robots collide with as with an obstacle. ${settles}`, input: objectSchema(), output: objectOutputSchema(), safe: false, idempotent: false },
    moveObject: { title: "Move an object", description: `Puts an object at a new pose. ${settles}`, input: moveObjectSchema(), output: objectOutputSchema(), safe: false, idempotent: false },
    removeObject: { title: "Remove an object", input: removeObstacleSchema(), output: { type: "object", properties: {} }, safe: false, idempotent: true },
  };
}

/** Validate and run a program of PTP, LIN and CIRC steps. */
function programActions(joints: JointSpec[], bounds: Bounds | null): Record<"validateProgram" | "runProgram", NoForms<ActionAffordance>> {
  return {
    validateProgram: {
      title: "Validate a program",
      description:
        "Plans the steps one after the other, each from where the previous one ends (PTP to joints or a pose, LIN, CIRC), without moving: per-step verdicts, the first refused step and why, each step's duration and the cycle time, the joint trajectory.",
      input: programInputSchema(joints, bounds),
      output: programReportSchema(),
      safe: true,
      idempotent: true,
    },
    runProgram: {
      title: "Run a program",
      description:
        "Plans the program as validateProgram does (refused with 422 and the report when a step is refused: nothing moves), then runs its timed trajectory; completes when it ends. With a relay, the physical robot then gets the steps one after the other. Asynchronous with Prefer: respond-async (query shows the running step and progress; cancel stops it).",
      input: programInputSchema(joints, bounds),
      output: programRunResultSchema(joints),
      safe: false,
      idempotent: false,
    },
  };
}

/** Solve and apply a virtual-to-real calibration from point pairs. */
function calibrateAction(): NoForms<ActionAffordance> {
  return {
    title: "Calibrate",
    description: "Solves x_real = s·R·x_virtual + t (Kabsch-Umeyama) from >= 3 non-collinear point pairs and applies it to every Cartesian input and output.",
    input: {
      type: "object",
      properties: {
        pairs: {
          type: "array",
          minItems: 3,
          items: {
            type: "object",
            properties: { real: xyzSchema("point in the real robot's frame", CALIBRATION_BOX), virtual: xyzSchema("same point in the twin's frame", CALIBRATION_BOX) },
            required: ["real", "virtual"],
          },
        },
        withScale: { type: "boolean", default: true },
      },
      required: ["pairs"],
    },
    output: calibrationResultSchema(),
    safe: false,
    idempotent: true,
  };
}

export function eventAffordances(joints: JointSpec[]): Record<string, NoForms<EventAffordance>> {
  const contact = contactSchema();
  return {
    collision: {
      title: "Collision",
      description: "A motion was stopped by contact.",
      data: {
        type: "object",
        properties: {
          pair: { type: "object", properties: { a: contact.properties?.a ?? {}, b: contact.properties?.b ?? {} }, required: ["a", "b"] },
          position: xyzSchema("contact point"),
          depth: { type: "number", unit: UNIT_M, minimum: 0 },
          joints: jointsSchema(joints, "Joint positions when the motion stopped"),
        },
        required: ["pair", "position", "depth", "joints"],
      },
    },
    divergence: {
      title: "Divergence",
      description:
        "While a command is relayed to the physical robot the twin follows (serve --follow), the physical robot's largest joint difference from the simulated motion at the same time passed the bound (serve --divergence-bound); once per relayed command.",
      data: {
        type: "object",
        properties: {
          joint: { type: "number", minimum: 0, description: "rad or m: the largest joint difference" },
          tcp: { type: "number", unit: UNIT_M, minimum: 0, description: "distance of the end effectors" },
          time: { type: "number", unit: UNIT_S, minimum: 0, description: "since the relayed command was sent" },
          bound: { type: "number", minimum: 0 },
          joints: jointsSchema(joints, "the physical robot's joints"),
          expected: jointsSchema(joints, "the simulated motion's joints at the same time"),
        },
        required: ["joint", "tcp", "time", "bound", "joints", "expected"],
      },
    },
    collisionImminent: {
      title: "Collision imminent",
      description:
        "The safety monitor (serve --follow): the physical robot, at its current joint velocity, would touch the named bodies within the horizon (or is within the clearance already); with --monitor stop (the default) the physical robot was stopped through its Thing. Once per approach.",
      data: {
        type: "object",
        properties: {
          contacts: { type: "array", items: { type: "object", properties: { a: contact.properties?.a ?? {}, b: contact.properties?.b ?? {} }, required: ["a", "b"] } },
          in: { type: "number", unit: UNIT_S, minimum: 0, description: "until the contact at the current joint velocity" },
          joints: jointsSchema(joints, "the physical robot's joints"),
          stopped: { type: "boolean", description: "the physical robot was stopped" },
          error: { type: "string", description: "why the stop failed" },
        },
        required: ["contacts", "in", "joints", "stopped"],
      },
    },
  };
}
