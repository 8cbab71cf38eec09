/**
 * Reading a twin folder (Contract 2): td.json, twin.json, scene.json, workspace.* and the optional
 * calibration.json. Errors name the folder and the file. The folder is a jail (see `Jail`): a hostile
 * folder can neither make serve read outside it nor make an error quote another file's bytes.
 */
import type { ConveyorSpec, ObjectAddParams, ObstacleAddParams, RobotLoadParams, SensorSpec } from "@robwot/sim-client";
import { existsSync, readFileSync, statSync } from "node:fs";
import { isAbsolute, join, relative, resolve, sep } from "node:path";
import { checkCalibration, jailFile, jsonErrorAt, realFolder, snippet, TWIN_FILES, type CalibrationFile, type JailVerdict, type TwinManifest, type WorkspaceSummary } from "@robwot/core";
import { servientError } from "./errors.js";

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
  /** scene document (obstacles, objects, other robots), as written by generate */
  scene: SceneDoc;
  workspace: WorkspaceSummary;
  calibration: CalibrationFile | null;
  urdfPath: string;
  stlPath: string;
  csvPath: string;
}

/** An obstacle of scene.json: what `obstacle.add` takes (the backend checks scene files the same way). */
export type SceneObstacle = ObstacleAddParams;
/** An object of scene.json (where it rests): what `object.add` takes. */
export type SceneObject = ObjectAddParams;

export interface SceneDoc {
  version?: number;
  obstacles?: SceneObstacle[];
  objects?: SceneObject[];
  /** conveyors (belt box, speed, state) and sensors (field-of-view box): no file paths, checked by the backend's scene schema */
  conveyors?: ConveyorSpec[];
  sensors?: SensorSpec[];
  robots?: unknown[];
  [k: string]: unknown;
}

const MAX_JSON_BYTES = 64 * 1024 * 1024;

const REASONS: Record<Exclude<JailVerdict, { ok: true }>["why"], string> = {
  outside: "resolves outside the twin folder",
  missing: "does not exist",
  "not-a-file": "is not a regular file",
  "not-a-path": "is not a file path",
};

/**
 * The folder as a jail: every path read from it (its fixed files and the entries of twin.json and
 * scene.json) must resolve inside its real path, or inside `roots` where those are allowed, after
 * symlinks; otherwise the folder is refused naming the file and the entry, before anything is read there.
 */
class Jail {
  readonly real: string;

  constructor(readonly dir: string) {
    this.real = realFolder(dir);
  }

  /** A path named by `entry` of `file`; null when optional and absent. */
  path(file: string, entry: string, value: unknown, opts: { required: boolean; roots?: readonly string[] }): string | null {
    // other roots take absolute paths only: a relative path is the folder's and may not climb out of it
    const roots = typeof value === "string" && isAbsolute(value) ? (opts.roots ?? []) : [];
    const v = jailFile([this.real, ...roots], this.real, value);
    if (v.ok) return v.real;
    if (v.why === "missing" && !opts.required) return null;
    const where = opts.roots !== undefined ? "the twin folder and the --mesh-root folders" : "the twin folder";
    const why = v.why === "outside" ? `resolves outside ${where}` : REASONS[v.why];
    throw servientError("E_TWIN_FOLDER", `${join(this.dir, file)}: ${entry} ${JSON.stringify(snippet(value, 80))} ${why}`, {
      folder: this.dir,
      file,
      entry,
      reason: v.why,
    });
  }

  /** One of the folder's own files (td.json, twin.json, ...): refused when it is a symlink out. */
  file(name: string, required: boolean): string | null {
    const v = jailFile([this.real], this.real, name);
    if (v.ok) return v.real;
    if (v.why === "missing") {
      if (!required) return null;
      throw servientError("E_TWIN_FOLDER", `twin folder ${this.dir} has no ${name} (run \`robwot generate\` first)`, { folder: this.dir, file: name });
    }
    throw servientError("E_TWIN_FOLDER", `${join(this.dir, name)} ${REASONS[v.why]}${v.why === "outside" ? " (a symlink to another file?)" : ""}: refused unread`, {
      folder: this.dir,
      file: name,
      reason: v.why,
    });
  }

  /** A JSON object of the folder; parse errors give the position, never the text (V8 quotes it). */
  json<T>(name: string, real: string | null): T | null {
    if (real === null) return null;
    const fail = (why: string): never => {
      throw servientError("E_TWIN_FOLDER", `${join(this.dir, name)}: ${why}`, { folder: this.dir, file: name });
    };
    if (statSync(real).size > MAX_JSON_BYTES) fail(`larger than ${MAX_JSON_BYTES} bytes`);
    const text = readFileSync(real, "utf8");
    let doc: unknown;
    try {
      doc = JSON.parse(text);
    } catch (err) {
      return fail(`invalid JSON${jsonErrorAt(err, text)}`);
    }
    if (typeof doc !== "object" || doc === null || Array.isArray(doc)) fail("not a JSON object");
    return doc as T;
  }
}

/**
 * scene.json's mesh obstacles and objects: a file relative to the folder or absolute, inside the folder or a
 * `--mesh-root` after symlinks. Files inside the folder become relative (served as `/<slug>/<file>`).
 */
function jailScene(jail: Jail, file: string, scene: SceneDoc, meshRoots: readonly string[]): SceneDoc {
  for (const key of ["obstacles", "objects", "robots", "conveyors", "sensors"] as const) {
    if (scene[key] !== undefined && !Array.isArray(scene[key])) {
      throw servientError("E_TWIN_FOLDER", `${join(jail.dir, file)}: ${key} must be an array`, { folder: jail.dir, file });
    }
  }
  // conveyors and sensors name no file: each an object with a name (the rest is the backend's scene schema's)
  for (const key of ["conveyors", "sensors"] as const) {
    scene[key]?.forEach((c: unknown, i) => {
      if (typeof c !== "object" || c === null || Array.isArray(c) || typeof (c as { name?: unknown }).name !== "string") {
        throw servientError("E_TWIN_FOLDER", `${join(jail.dir, file)}: ${key}[${i}] must be an object with a name`, { folder: jail.dir, file, entry: `${key}[${i}]` });
      }
    });
  }
  const robots = scene.robots === undefined ? undefined : scene.robots.map((r, i) => jailSceneRobot(jail, file, r, i));
  const obstacles = scene.obstacles?.map((ob, i) => jailMesh(jail, file, ob, i, "obstacle", meshRoots));
  const objects = scene.objects?.map((ob, i) => jailMesh(jail, file, ob, i, "object", meshRoots));
  return { ...scene, ...(obstacles === undefined ? {} : { obstacles }), ...(objects === undefined ? {} : { objects }), ...(robots === undefined ? {} : { robots }) };
}

function jailMesh<T extends SceneObstacle>(jail: Jail, file: string, ob: T, i: number, kind: string, meshRoots: readonly string[]): T {
  const shape = (ob as Partial<SceneObstacle> | null)?.shape as { type?: unknown; file?: unknown } | undefined;
  if (shape?.type !== "mesh") return ob;
  const name = typeof ob.name === "string" ? ob.name : String(i);
  const real = jail.path(file, `${kind} ${JSON.stringify(snippet(name, 40))} mesh`, shape.file, { required: true, roots: meshRoots })!;
  const rel = relative(jail.real, real);
  const inFolder = rel !== "" && !rel.startsWith("..") && !isAbsolute(rel);
  return { ...ob, shape: { ...ob.shape, file: inFolder ? rel.split(sep).join("/") : real } };
}

/**
 * A scene's other robot, loaded from inside the folder (generate exports it to `robots/<id>/`): its URDF
 * and SRDF resolve inside the folder after symlinks and are given to the backend as those real paths; it
 * may name no package roots (they would open folders outside the jail).
 */
function jailSceneRobot(jail: Jail, file: string, robot: unknown, index: number): Record<string, unknown> {
  const r = (typeof robot === "object" && robot !== null ? robot : {}) as Record<string, unknown>;
  const what = `robot ${JSON.stringify(snippet(typeof r.id === "string" ? r.id : String(index), 40))}`;
  if (r.packageRoots !== undefined) {
    throw servientError("E_TWIN_FOLDER", `${join(jail.dir, file)}: ${what} names packageRoots: a twin folder's robots load from inside it (regenerate the twin with robwot generate)`, { folder: jail.dir, file, entry: `${what} packageRoots` });
  }
  const urdf = jail.path(file, `${what} urdf`, r.urdf, { required: true })!;
  const srdf = r.srdf === undefined ? undefined : jail.path(file, `${what} srdf`, r.srdf, { required: true })!;
  return { ...r, urdf, ...(srdf === undefined ? {} : { srdf }) };
}

/** workspace.json's bounds (and reachBounds, the TD's Cartesian limits after a calibration): finite, min <= max. */
function checkBounds(dir: string, ws: WorkspaceSummary): void {
  for (const key of ["bounds", "reachBounds"] as const) {
    if (key === "reachBounds" && ws?.reachBounds === undefined) continue; // folders written before it
    const { min, max } = (ws?.[key] ?? {}) as Partial<WorkspaceSummary["bounds"]>;
    const ok = [min, max].every((v) => Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number" && Number.isFinite(x)));
    if (!ok || min!.some((m, i) => m > max![i]!)) {
      throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.summary)}: ${key} must be {min, max} of 3 finite numbers with min <= max, got ${JSON.stringify(ws?.[key] ?? null)} (regenerate it with robwot generate)`, {
        folder: dir,
        file: TWIN_FILES.summary,
      });
    }
  }
}

/** twin.json's `robot.gripper` (`generate --gripper`), when there: its kind, finger joints, time and capture
 *  distance as the backend's `gripper.configure` takes them (ranges checked there). */
function checkGripper(dir: string, g: unknown): void {
  if (g === undefined) return;
  const r = (typeof g === "object" && g !== null ? g : {}) as Record<string, unknown>;
  const finite = (v: unknown): boolean => typeof v === "number" && Number.isFinite(v) && v >= 0;
  const ok = (r.kind === "fingers" || r.kind === "suction") && finite(r.time) && finite(r.capture)
    && (r.joints === undefined || (Array.isArray(r.joints) && r.joints.every((j) => typeof j === "string")));
  if (!ok) {
    throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.manifest)}: robot.gripper must be {kind: "fingers" | "suction", joints?: [name], time: s, capture: m}`, { folder: dir, file: TWIN_FILES.manifest, field: "robot.gripper" });
  }
}

/**
 * Reads and checks a twin folder. Every path read from it resolves inside it after symlinks (scene mesh
 * obstacles: inside it or a `meshRoots` folder), else the folder is refused naming the file and entry.
 */
export function loadTwinFolder(folder: string, meshRoots: readonly string[] = []): TwinFolder {
  const dir = resolve(folder);
  if (!existsSync(dir) || !statSync(dir).isDirectory()) {
    throw servientError("E_TWIN_FOLDER", `twin folder ${dir} does not exist`, { folder: dir });
  }
  const jail = new Jail(dir);
  const td = jail.json<TdDocument>(TWIN_FILES.td, jail.file(TWIN_FILES.td, true))!;
  const manifest = jail.json<TwinManifest>(TWIN_FILES.manifest, jail.file(TWIN_FILES.manifest, true))!;
  if (typeof td.title !== "string" || td.title.length === 0) {
    throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.td)}: no title`, { folder: dir, file: TWIN_FILES.td });
  }
  const robot = manifest.robot as Partial<TwinManifest["robot"]> | undefined;
  if (typeof robot !== "object" || robot === null || typeof robot.urdf !== "string") {
    throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.manifest)}: no robot.urdf`, { folder: dir, file: TWIN_FILES.manifest });
  }
  const urdfPath = jail.path(TWIN_FILES.manifest, "robot.urdf", robot.urdf, { required: true })!;
  if (robot.srdf !== undefined) jail.path(TWIN_FILES.manifest, "robot.srdf", robot.srdf, { required: true });
  const home = robot.home as { joints?: unknown; from?: unknown } | undefined;
  if (home !== undefined) {
    const joints = home?.joints;
    const ok = typeof joints === "object" && joints !== null && !Array.isArray(joints) && Object.values(joints).every((v) => typeof v === "number" && Number.isFinite(v)) && typeof home?.from === "string";
    if (!ok) throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.manifest)}: robot.home must be {joints: {name: finite number}, from: text}`, { folder: dir, file: TWIN_FILES.manifest, field: "robot.home" });
  }
  checkGripper(dir, robot.gripper as unknown);
  const couplings = robot.couplings as unknown;
  if (couplings !== undefined && !(Array.isArray(couplings) && couplings.every((c) => typeof c === "string"))) {
    throw servientError("E_TWIN_FOLDER", `${join(dir, TWIN_FILES.manifest)}: robot.couplings must be a list of "FOLLOWER=EXPR" texts`, { folder: dir, file: TWIN_FILES.manifest, field: "robot.couplings" });
  }
  const sceneFile = manifest.scene === undefined || manifest.scene === "" ? TWIN_FILES.scene : manifest.scene;
  const sceneReal = jail.path(TWIN_FILES.manifest, "scene", sceneFile, { required: false });
  const sceneName = typeof sceneFile === "string" ? sceneFile : TWIN_FILES.scene;
  const scene = jailScene(jail, sceneName, jail.json<SceneDoc>(sceneName, sceneReal) ?? {}, meshRoots.map(realFolder));
  const workspace = jail.json<WorkspaceSummary>(TWIN_FILES.summary, jail.file(TWIN_FILES.summary, true))!;
  checkBounds(dir, workspace);
  for (const name of [TWIN_FILES.pointCloud, TWIN_FILES.surface, TWIN_FILES.reachability]) jail.file(name, false);
  const calibration = jail.json<CalibrationFile>(TWIN_FILES.calibration, jail.file(TWIN_FILES.calibration, false));
  if (calibration !== null) {
    try {
      checkCalibration(calibration);
    } catch (err) {
      const file = join(dir, TWIN_FILES.calibration);
      throw servientError("E_TWIN_FOLDER", `${file}: ${(err as Error).message} (fix or delete the file; calibrate writes it)`, { folder: dir, file: TWIN_FILES.calibration });
    }
  }
  return {
    dir,
    td,
    manifest,
    scene,
    workspace,
    calibration,
    urdfPath,
    stlPath: join(dir, TWIN_FILES.surface),
    csvPath: join(dir, TWIN_FILES.pointCloud),
  };
}

/** `robot.load`'s parameters for a twin folder's robot as generated (its files, base, end effector,
 *  couplings; never decomposed again: the folder holds its convex parts). */
export function robotLoadParams(folder: TwinFolder, id: string): RobotLoadParams {
  const m = folder.manifest.robot;
  return {
    urdf: folder.urdfPath,
    id,
    ...(m.basePosition ? { basePosition: m.basePosition } : {}),
    ...(m.baseOrientation ? { baseOrientation: m.baseOrientation } : {}),
    ...(m.eeLink ? { eeLink: m.eeLink } : {}),
    ...(m.couplings !== undefined ? { couplings: m.couplings } : {}),
    decompose: false,
  };
}
