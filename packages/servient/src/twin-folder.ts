/**
 * Reading a twin folder (Contract 2): td.json, twin.json, scene.json, workspace.* and the optional
 * calibration.json. Errors name the folder and the file.
 */
import type { ObstacleAddParams } from "@robwot/sim-client";
import { existsSync, readFileSync } from "node:fs";
import { join, resolve } from "node:path";
import { checkCalibration, type CalibrationFile, type TwinManifest, type WorkspaceSummary } from "@robwot/core";
import { ServientError } from "./errors.js";

/** The TD document as generated (forms are replaced when served). */
export type TdDocument = Record<string, unknown> & {
  id?: string;
  title: string;
  properties?: Record<string, Record<string, unknown>>;
  actions?: Record<string, Record<string, unknown>>;
  events?: Record<string, Record<string, unknown>>;
  links?: { href: string; rel?: string; type?: string }[];
};

export interface TwinFolder {
  dir: string;
  td: TdDocument;
  manifest: TwinManifest;
  /** scene document (obstacles, other robots), as written by generate */
  scene: SceneDoc;
  workspace: WorkspaceSummary;
  calibration: CalibrationFile | null;
  urdfPath: string;
  stlPath: string;
  csvPath: string;
}

/** An obstacle of scene.json: what `obstacle.add` takes (the backend checks scene files the same way). */
export type SceneObstacle = ObstacleAddParams;

export interface SceneDoc {
  version?: number;
  obstacles?: SceneObstacle[];
  robots?: unknown[];
  [k: string]: unknown;
}

function readJson<T>(dir: string, file: string, required: boolean): T | null {
  const path = join(dir, file);
  if (!existsSync(path)) {
    if (!required) return null;
    throw new ServientError(400, "E_TWIN_FOLDER", `twin folder ${dir} has no ${file} (run \`robwot generate\` first)`, {
      folder: dir,
      file,
    });
  }
  try {
    return JSON.parse(readFileSync(path, "utf8")) as T;
  } catch (err) {
    throw new ServientError(400, "E_TWIN_FOLDER", `${path}: invalid JSON: ${(err as Error).message}`, { folder: dir, file });
  }
}

/** workspace.json's bounds (and reachBounds, the TD's Cartesian limits after a calibration): finite, min <= max. */
function checkBounds(dir: string, ws: WorkspaceSummary): void {
  for (const key of ["bounds", "reachBounds"] as const) {
    if (key === "reachBounds" && ws?.reachBounds === undefined) continue; // folders written before it
    const { min, max } = (ws?.[key] ?? {}) as Partial<WorkspaceSummary["bounds"]>;
    const ok = [min, max].every((v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number" && Number.isFinite(x)));
    if (!ok || min!.some((m, i) => m > max![i]!)) {
      throw new ServientError(400, "E_TWIN_FOLDER", `${join(dir, "workspace.json")}: ${key} must be {min, max} of 3 finite numbers with min <= max, got ${JSON.stringify(ws?.[key] ?? null)} (regenerate it with robwot generate)`, {
        folder: dir,
        file: "workspace.json",
      });
    }
  }
}

export function loadTwinFolder(folder: string): TwinFolder {
  const dir = resolve(folder);
  if (!existsSync(dir)) {
    throw new ServientError(400, "E_TWIN_FOLDER", `twin folder ${dir} does not exist`, { folder: dir });
  }
  const td = readJson<TdDocument>(dir, "td.json", true) as TdDocument;
  const manifest = readJson<TwinManifest>(dir, "twin.json", true) as TwinManifest;
  if (typeof td.title !== "string" || td.title.length === 0) {
    throw new ServientError(400, "E_TWIN_FOLDER", `${join(dir, "td.json")}: no title`, { folder: dir, file: "td.json" });
  }
  if (!manifest.robot || typeof manifest.robot.urdf !== "string") {
    throw new ServientError(400, "E_TWIN_FOLDER", `${join(dir, "twin.json")}: no robot.urdf`, { folder: dir, file: "twin.json" });
  }
  const scene = readJson<SceneDoc>(dir, manifest.scene || "scene.json", false) ?? {};
  const workspace = readJson<WorkspaceSummary>(dir, "workspace.json", true) as WorkspaceSummary;
  checkBounds(dir, workspace);
  const calibration = readJson<CalibrationFile>(dir, "calibration.json", false);
  if (calibration !== null) {
    try {
      checkCalibration(calibration);
    } catch (err) {
      const file = join(dir, "calibration.json");
      throw new ServientError(400, "E_TWIN_FOLDER", `${file}: ${(err as Error).message} (fix or delete the file; calibrate writes it)`, { folder: dir, file: "calibration.json" });
    }
  }
  return {
    dir,
    td,
    manifest,
    scene,
    workspace,
    calibration,
    urdfPath: join(dir, manifest.robot.urdf),
    stlPath: join(dir, "workspace.stl"),
    csvPath: join(dir, "workspace.csv"),
  };
}
