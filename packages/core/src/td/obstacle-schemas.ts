/** Data schemas of the scene-editing actions (obstacle shapes as in Contract 1). */
import { UNIT_M, vec3Schema } from "./schemas.js";
import type { DataSchema } from "./types.js";

const positive = (description: string): DataSchema => ({ type: "number", unit: UNIT_M, exclusiveMinimum: 0, description });

export function shapeSchema(): DataSchema {
  return {
    description: "Obstacle shape",
    oneOf: [
      {
        type: "object",
        properties: { type: { type: "string", const: "box" }, size: { ...vec3Schema("full extents x, y, z"), items: { type: "number", unit: UNIT_M, exclusiveMinimum: 0 } } },
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
          scale: { oneOf: [{ type: "number", exclusiveMinimum: 0 }, vec3Schema("per-axis scale", null)] },
        },
        required: ["type", "file"],
      },
    ],
  };
}

function placement(): Record<string, DataSchema> {
  return {
    position: vec3Schema("position in the world frame"),
    orientation: { type: "array", items: { type: "number" }, minItems: 4, maxItems: 4, description: "quaternion [x, y, z, w]" },
    rpy: { type: "array", items: { type: "number", unit: "rad" }, minItems: 3, maxItems: 3, description: "roll, pitch, yaw (alternative to orientation)" },
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
