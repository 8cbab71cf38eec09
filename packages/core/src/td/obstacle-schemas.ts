/** Data schemas of the scene-editing actions (obstacle shapes as in Contract 1). */
import { VALUE_SCHEMAS } from "../backend-contract.js";
import { MIN_QUATERNION_NORM, UNIT_M, vec3Schema } from "./schemas.js";
import type { DataSchema } from "./types.js";

/** Largest |coordinate| (m) of a position, |angle| (rad) of an rpy triple, and largest size, radius,
 *  length or mesh scale: the backend contract's range (a robot cell is metres). */
export const MAX_WORLD_COORDINATE = VALUE_SCHEMAS.Position.items.maximum;

/** An obstacle name as the backend accepts it (the contract's `Name`). */
const NAME: DataSchema = { type: "string", minLength: VALUE_SCHEMAS.Name.minLength, maxLength: VALUE_SCHEMAS.Name.maxLength };

const positive = (description: string, unit: string | null = UNIT_M): DataSchema => ({
  type: "number",
  ...(unit === null ? {} : { unit }),
  exclusiveMinimum: 0,
  maximum: MAX_WORLD_COORDINATE,
  description,
});

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

function shapeMembers(): (DataSchema & { properties: Record<string, DataSchema> })[] {
  return [
    {
      type: "object",
      properties: { type: { type: "string", const: "box" }, size: { ...vec3Schema("full extents x, y, z"), items: positive("extent") } },
      required: ["type", "size"],
    },
    {
      type: "object",
      properties: { type: { type: "string", const: "sphere" }, radius: positive("radius") },
      required: ["type", "radius"],
    },
    {
      type: "object",
      properties: { type: { type: "string", const: "cylinder" }, radius: positive("radius"), length: positive("length along z") },
      required: ["type", "radius", "length"],
    },
    {
      type: "object",
      properties: {
        type: { type: "string", const: "mesh" },
        file: { type: "string", minLength: VALUE_SCHEMAS.FilePath.minLength, maxLength: VALUE_SCHEMAS.FilePath.maxLength },
        scale: { ...vec3Schema("scale per axis x, y, z", null), items: positive("scale", null) },
      },
      required: ["type", "file"],
    },
  ];
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
