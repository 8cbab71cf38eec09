/** Data schemas of the scene-editing actions and the `objects` property (obstacle shapes as in Contract 1;
 *  an object is an obstacle's shape and pose with a mass). */
import { OBSTACLE_SHAPE, VALUE_SCHEMAS } from "../backend-contract.js";
import { MIN_QUATERNION_NORM, UNIT_KG, UNIT_M, vec3Schema } from "./schemas.js";
import type { DataSchema } from "./types.js";

/** Largest |coordinate| (m) of a position, |angle| (rad) of an rpy triple, and largest size, radius,
 *  length or mesh scale: the backend contract's range (a robot cell is metres). */
export const MAX_WORLD_COORDINATE = VALUE_SCHEMAS.Position.items.maximum;

/** An obstacle name as the backend accepts it (the contract's `Name`). */
const NAME: DataSchema = { type: "string", minLength: VALUE_SCHEMAS.Name.minLength, maxLength: VALUE_SCHEMAS.Name.maxLength };

const bounded = (description: string, unit: string): DataSchema => ({
  ...vec3Schema(description),
  items: { type: "number", unit, minimum: -MAX_WORLD_COORDINATE, maximum: MAX_WORLD_COORDINATE },
});

export function shapeSchema(): DataSchema {
  const members = shapeMembers();
  return {
    type: "object",
    description: "Obstacle shape: box (full extents), sphere, cylinder (along local z) or mesh",
    // every member's properties, so that a consumer reading only `properties` sees them all
    properties: {
      ...(Object.assign({}, ...members.map((m) => m.properties)) as Record<string, DataSchema>),
      type: { type: "string", enum: members.map((m) => m.properties.type?.const as string) },
    },
    required: ["type"],
    oneOf: members,
  };
}

/** Units of the shape's lengths (metres); a scale has none. */
const SHAPE_UNITS: Record<string, string> = { size: UNIT_M, radius: UNIT_M, length: UNIT_M };

type ContractSchema = { readonly [k: string]: unknown };

/**
 * A contract schema of the obstacle shape as a TD data schema: every schema typed (consumers build typed
 * schemas from it), lengths with their unit; where the contract accepts a number or an array (a uniform
 * or per-axis mesh scale) the TD offers the array, which the backend accepts as well.
 */
function tdSchema(schema: ContractSchema, name = ""): DataSchema {
  const alternatives = schema["oneOf"] as readonly ContractSchema[] | undefined;
  if (alternatives) return tdSchema(alternatives.find((m) => m["type"] === "array") ?? alternatives[0]!, name);
  if ("const" in schema) return { type: "string", const: schema["const"] };
  const out: DataSchema = { type: schema["type"] as DataSchema["type"] };
  for (const key of ["minimum", "maximum", "exclusiveMinimum", "minItems", "maxItems", "minLength", "maxLength", "description"] as const) {
    if (schema[key] !== undefined) (out as Record<string, unknown>)[key] = schema[key];
  }
  if (out.type === "number" && SHAPE_UNITS[name]) out.unit = SHAPE_UNITS[name];
  if (schema["items"]) out.items = tdSchema(schema["items"] as ContractSchema, name);
  if (schema["properties"]) {
    out.properties = Object.fromEntries(Object.entries(schema["properties"] as Record<string, ContractSchema>).map(([k, v]) => [k, tdSchema(v, k)]));
    out.required = [...(schema["required"] as readonly string[])];
  }
  return out;
}

/** One member per shape of the contract's `ObstacleShape` (box, sphere, cylinder, mesh). */
function shapeMembers(): (DataSchema & { properties: Record<string, DataSchema> })[] {
  return OBSTACLE_SHAPE.oneOf.map((m) => tdSchema(m) as DataSchema & { properties: Record<string, DataSchema> });
}

const ORIENTATION: DataSchema = {
  type: "array",
  items: { type: "number" },
  minItems: 4,
  maxItems: 4,
  description: `quaternion [x, y, z, w], normalised; its norm must be >= ${MIN_QUATERNION_NORM}`,
};
const RPY: DataSchema = bounded("roll, pitch, yaw (alternative to orientation)", "rad");

/**
 * An object of `common` properties with the orientation given as a quaternion, as roll-pitch-yaw, or
 * not at all — never both: two closed members, the second requiring `rpy`, so exactly one matches.
 */
function withOrientation(description: string, common: Record<string, DataSchema>, required: string[]): DataSchema {
  return {
    type: "object",
    description: `${description}; give orientation (quaternion) or rpy, not both`,
    properties: { ...common, orientation: ORIENTATION, rpy: RPY },
    required,
    oneOf: [
      { type: "object", properties: { ...common, orientation: ORIENTATION }, required, additionalProperties: false },
      { type: "object", properties: { ...common, rpy: RPY }, required: [...required, "rpy"], additionalProperties: false },
    ],
  };
}

const COLOR: DataSchema = {
  type: "array",
  items: { type: "number", minimum: 0, maximum: 1 },
  minItems: 3,
  maxItems: 4,
  description: "display colour [r, g, b] or [r, g, b, a] in [0, 1]",
};

export function obstacleSchema(): DataSchema {
  const common: Record<string, DataSchema> = { name: NAME, shape: shapeSchema(), position: bounded("position in the world frame", UNIT_M), color: COLOR };
  return withOrientation("Obstacle", common, ["name", "shape", "position"]);
}

/** An obstacle as the twin reports it (orientation always as a quaternion). */
export function obstacleOutputSchema(): DataSchema {
  return {
    type: "object",
    description: "Obstacle",
    properties: { name: { type: "string" }, shape: shapeSchema(), position: bounded("position in the world frame", UNIT_M), orientation: ORIENTATION, color: COLOR },
    required: ["name", "shape", "position", "orientation"],
  };
}

export function moveObstacleSchema(): DataSchema {
  return withOrientation("New pose of an obstacle", { name: NAME, position: bounded("position in the world frame", UNIT_M) }, ["name", "position"]);
}

export function removeObstacleSchema(): DataSchema {
  return { type: "object", properties: { name: NAME }, required: ["name"] };
}

/** An object's mass (kg): the contract's `Mass` (range; its default where a request may leave it out). */
const MASS: DataSchema = { type: "number", unit: UNIT_KG, exclusiveMinimum: VALUE_SCHEMAS.Mass.exclusiveMinimum, maximum: VALUE_SCHEMAS.Mass.maximum, description: "mass (kg)" };

export function objectSchema(): DataSchema {
  const common: Record<string, DataSchema> = { name: NAME, shape: shapeSchema(), position: bounded("position in the world frame it is let go at", UNIT_M), color: COLOR, mass: { ...MASS, default: VALUE_SCHEMAS.Mass.default } };
  return withOrientation("Object (it then settles onto what is below it, or onto the floor z = 0)", common, ["name", "shape", "position"]);
}

/** An object as the twin reports it: where it rests (world frame), orientation always as a quaternion. */
export function objectOutputSchema(): DataSchema {
  return {
    type: "object",
    description: "Object at its live pose",
    properties: { name: { type: "string" }, shape: shapeSchema(), position: bounded("position in the world frame", UNIT_M), orientation: ORIENTATION, color: COLOR, mass: MASS },
    required: ["name", "shape", "position", "orientation", "mass"],
  };
}

export function moveObjectSchema(): DataSchema {
  return withOrientation("New pose of an object (it then settles)", { name: NAME, position: bounded("position in the world frame it is let go at", UNIT_M) }, ["name", "position"]);
}

/** The `objects` property: every object of the shared world at its live pose. */
export function objectsSchema(): DataSchema {
  return { type: "array", items: objectOutputSchema(), maxItems: VALUE_SCHEMAS.SceneObjects.maxItems, description: "every object of the world at its live pose (world frame)" };
}
