/** Data schemas of the scene-editing actions (obstacle shapes as in Contract 1). */
import { UNIT_M, vec3Schema } from "./schemas.js";
import type { DataSchema } from "./types.js";

/** Largest |coordinate| (m) of a position, |angle| (rad) of an rpy triple, and largest size, radius,
 *  length or mesh scale: a robot cell is metres (the backend refuses the same range). */
export const MAX_WORLD_COORDINATE = 1e4;

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
  return {
    description: "Obstacle shape",
    oneOf: [
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
          file: { type: "string", minLength: 1 },
          scale: { oneOf: [positive("uniform scale", null), { ...vec3Schema("per-axis scale", null), items: positive("scale", null) }] },
        },
        required: ["type", "file"],
      },
    ],
  };
}

function placement(): Record<string, DataSchema> {
  return {
    position: bounded("position in the world frame", UNIT_M),
    orientation: { type: "array", items: { type: "number" }, minItems: 4, maxItems: 4, description: "quaternion [x, y, z, w], normalised; its norm must be >= 1e-6" },
    rpy: { ...bounded("roll, pitch, yaw (alternative to orientation)", "rad") },
  };
}

export function obstacleSchema(): DataSchema {
  return {
    type: "object",
    description: "Obstacle (Contract 1)",
    properties: { name: { type: "string", minLength: 1 }, shape: shapeSchema(), ...placement() },
    required: ["name", "shape", "position"],
  };
}

export function moveObstacleSchema(): DataSchema {
  return {
    type: "object",
    properties: { name: { type: "string", minLength: 1 }, ...placement() },
    required: ["name", "position"],
  };
}

export function removeObstacleSchema(): DataSchema {
  return { type: "object", properties: { name: { type: "string", minLength: 1 } }, required: ["name"] };
}
