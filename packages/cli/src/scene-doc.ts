/**
 * The twin's `scene.json`: the world as the backend has it after loading (Contract 2, scene schema
 * `sim-backend/src/robwot_sim/schemas/scene.schema.json`), with mesh obstacles and objects copied into the
 * folder so it stays self-contained; objects where they rest; conveyors (their state) and sensors (without
 * their readings).
 */
import { copyFileSync, existsSync, mkdirSync, readFileSync } from "node:fs";
import { basename, join } from "node:path";
import { TWIN_FOLDERS } from "@robwot/core";
import type { WorldList } from "@robwot/sim-client";

export interface SceneDoc {
  version: 1;
  name?: string;
  description?: string;
  obstacles: Record<string, unknown>[];
  objects?: Record<string, unknown>[];
  /** the conveyors as the world holds them (belt box, speed, end stop, state) */
  conveyors?: Record<string, unknown>[];
  /** the sensors (kind, field-of-view box), without their readings */
  sensors?: Record<string, unknown>[];
  robots: Record<string, unknown>[];
}

function sourceMeta(sceneFile: string | undefined): { name?: string; description?: string } {
  if (!sceneFile) return {};
  try {
    const doc = JSON.parse(readFileSync(sceneFile, "utf8")) as { name?: unknown; description?: unknown };
    return {
      ...(typeof doc.name === "string" ? { name: doc.name } : {}),
      ...(typeof doc.description === "string" ? { description: doc.description } : {}),
    };
  } catch {
    return {};
  }
}

/**
 * Builds the normalised scene from `world.list` (our own robot excluded) and copies mesh obstacle and
 * object files into `<dir>/meshes/scene/`, rewriting their paths relative to the twin folder; the other robots' URDFs
 * are the exported copies `robotUrdfs` names (id -> path relative to the twin folder).
 */
export function sceneDocument(world: WorldList, ownRobot: string, dir: string, sceneFile?: string, robotUrdfs: ReadonlyMap<string, string> = new Map()): SceneDoc {
  const obstacles = world.obstacles.map((o) => inFolder(o, dir));
  const objects = world.objects.map((o) => inFolder(o, dir));
  const robots = world.robots
    .filter((r) => r.id !== ownRobot)
    .map((r) => ({ id: r.id, urdf: robotUrdfs.get(r.id) ?? r.urdf, basePosition: r.basePosition, baseOrientation: r.baseOrientation, eeLink: r.eeLink }));
  // the conveyors in their state now; a sensor's reading is the world's, not part of a scene document
  const conveyors = (world.conveyors ?? []).map((c) => ({ ...c }));
  const sensors = (world.sensors ?? []).map(({ reading: _reading, ...s }) => s);
  return {
    version: 1,
    ...sourceMeta(sceneFile),
    obstacles,
    ...(objects.length > 0 ? { objects } : {}),
    ...(conveyors.length > 0 ? { conveyors } : {}),
    ...(sensors.length > 0 ? { sensors } : {}),
    robots,
  };
}

/** An obstacle or object of `world.list` for scene.json: a mesh file copied into `<dir>/meshes/scene/`. */
function inFolder(body: object, dir: string): Record<string, unknown> {
  const ob = { ...(body as Record<string, unknown>) };
  const shape = ob["shape"] as Record<string, unknown> | undefined;
  if (shape?.["type"] === "mesh" && typeof shape["file"] === "string" && existsSync(shape["file"])) {
    const rel = join(TWIN_FOLDERS.sceneMeshes, `${String(ob["name"])}-${basename(shape["file"])}`);
    mkdirSync(join(dir, TWIN_FOLDERS.sceneMeshes), { recursive: true });
    copyFileSync(shape["file"], join(dir, rel));
    ob["shape"] = { ...shape, file: rel };
  }
  if (ob["orientation"] !== undefined) delete ob["rpy"];
  return ob;
}
