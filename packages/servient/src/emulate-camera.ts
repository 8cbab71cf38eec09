/**
 * The depth camera of `robwot emulate --camera`: the emulated cell as a sensor fixed in it sees it, served
 * as the emulated Thing's `pointCloud` property (a binary PLY, `camera.capture`).
 *
 * The cell is the emulator's own backend world: the emulated robot (id `emulated`) and a scene file loaded
 * beside it at start (`--scene`, else the twin folder's own scene when it holds something to see). A scene
 * robot standing at the emulated robot's base is that robot (two robots cannot stand on one base: a scene
 * that placed the twin's robot, as `generate --scene` takes it): it is removed again, with a warning. A
 * scene naming anything `emulated` is refused.
 *
 * A frame is captured on demand: the backend's robot set to the controller's true joints now, then the
 * rays cast. One capture runs at a time: a request arriving while one runs shares its frame; a request
 * never gets a frame that was finished before it arrived.
 * Each frame draws its noise from a seed of its own (a counter), so consecutive frames differ as a real
 * sensor's do. The file is written into a temporary folder of the emulator, read back, and the folder is
 * removed on close.
 */
import { existsSync, mkdtempSync, readFileSync, rmSync, statSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { TWIN_FILES, type Vec3 } from "@robwot/core";
import type { SimClient } from "@robwot/sim-client";
import type { PropertyBytes } from "./affordance-routes.js";
import { fromBackendError, servientError } from "./errors.js";
import type { SceneDoc, TwinFolder } from "./twin-folder.js";

/** The camera of `startEmulator`'s `camera` option (world frame, metres). */
export interface EmulatorCamera {
  /** the camera's position (m) */
  position: Vec3;
  /** the point it looks at (m); not straight above or below `position` (the image's up is the world's z) */
  target: Vec3;
  /** pixels */
  width: number;
  height: number;
  /** m: the depth noise's standard deviation at 1 m (growing with the square of the depth) */
  noise: number;
  /** the share of pixels returning nothing */
  dropout: number;
  /** the scene file the camera sees (`world.loadScene`'s `path`); default: the twin folder's own scene when
   *  it holds something to see */
  scene?: string;
}

/** The id of the emulated robot in its backend. */
export const EMULATED_ID = "emulated";

/** The media type of a frame, and what its bytes are (the property's description). */
export const POINT_CLOUD_TYPE = "application/octet-stream";
const POINT_CLOUD_DESCRIPTION =
  "a depth frame of the emulated cell, captured on request: a binary PLY (binary_little_endian; element vertex of float32 x y z, m) in the camera's optical frame (z forward, x right, y down), its `comment robwot viewpoint x y z qx qy qz qw` line the camera's pose in the world";

/** The `pointCloud` property as node-wot produces it (its forms' media type set where they are served). */
export const POINT_CLOUD_AFFORDANCE = { readOnly: true, observable: false, description: POINT_CLOUD_DESCRIPTION };

/** sin of the angle between view and up below which the backend refuses a camera (`sim/camera.py`) */
const PARALLEL = 1e-6;
/** m: a scene robot's base this close to the emulated robot's stands on it */
const SAME_BASE = 1e-3;
/** the 32-bit seeds of `camera.capture` */
const SEEDS = 2 ** 32;

/** Why `camera` cannot capture (the backend's conditions), or null. */
export function cameraProblem(camera: EmulatorCamera): string | null {
  const view = camera.target.map((t, i) => t - (camera.position[i] ?? 0));
  const length = Math.hypot(...view);
  if (!(length > 1e-9)) return "the camera's target must differ from its position";
  if (Math.hypot(view[0] ?? 0, view[1] ?? 0) / length < PARALLEL) return "the camera must not look straight up or down (its image's up is the world's z)";
  return null;
}

/** The scene file the camera sees: the given one, else the twin folder's scene when it holds obstacles,
 *  objects, conveyors or other robots; null when there is none. */
export function cameraScene(folder: TwinFolder, given: string | undefined): string | null {
  if (given !== undefined) return given;
  const s = folder.scene;
  const bodies = [s.obstacles, s.objects, s.conveyors, s.robots].some((list) => (list?.length ?? 0) > 0);
  const file = typeof folder.manifest.scene === "string" && folder.manifest.scene !== "" ? folder.manifest.scene : TWIN_FILES.scene;
  return bodies && existsSync(join(folder.dir, file)) ? join(folder.dir, file) : null;
}

/** The names a scene file gives its robots, obstacles, objects and conveyors (one namespace in the backend);
 *  none when it cannot be read as JSON (the backend then says why, naming the file). */
function sceneNames(file: string): { kind: string; name: unknown }[] {
  let doc: SceneDoc;
  try {
    // the backend's own cap on a scene file: a larger one is refused there
    if (statSync(file).size > 50 * 1024 * 1024) return [];
    doc = JSON.parse(readFileSync(file, "utf8")) as SceneDoc;
  } catch {
    return [];
  }
  const entries = (key: string): Record<string, unknown>[] => (Array.isArray(doc?.[key]) ? (doc[key] as Record<string, unknown>[]) : []);
  return [
    ...entries("robots").map((r) => ({ kind: "robot", name: r?.["id"] })),
    ...["obstacles", "objects", "conveyors"].flatMap((key) => entries(key).map((o) => ({ kind: key.slice(0, -1), name: o?.["name"] }))),
  ];
}

/**
 * Loads `file` into the emulator's backend beside the emulated robot: a scene naming anything `emulated` is
 * refused before it is loaded; a scene robot standing at the emulated robot's base is removed again (warned).
 */
export async function loadCameraScene(sim: SimClient, file: string): Promise<void> {
  const clash = sceneNames(file).find((e) => e.name === EMULATED_ID);
  if (clash) {
    throw servientError("E_SCENE", `the scene ${file} names its ${clash.kind} "${EMULATED_ID}", the emulated robot's id: rename it in the scene`, { file, [clash.kind]: EMULATED_ID });
  }
  await sim.loadScene({ path: file, decompose: false });
  const robots = (await sim.listWorld()).robots;
  const base = robots.find((r) => r.id === EMULATED_ID)?.basePosition ?? [0, 0, 0];
  for (const r of robots) {
    if (r.id === EMULATED_ID || Math.hypot(...r.basePosition.map((v, i) => v - (base[i] ?? 0))) > SAME_BASE) continue;
    await sim.removeRobot({ robot: r.id });
    process.emitWarning(`robwot emulate: the scene ${file} places robot "${r.id}" on the emulated robot's base: taken to be the emulated robot itself (left out)`, { code: "ROBWOT_SCENE_ROBOT" });
  }
}

/** Frames of the camera on demand, one capture at a time. */
export class DepthCamera {
  private readonly dir = mkdtempSync(join(tmpdir(), "robwot-emulate-camera-"));
  private readonly file = join(this.dir, "frame.ply");
  private running: Promise<PropertyBytes> | null = null;
  private frames = 0;

  /**
   * @param joints the controller's true joints now (the backend's controllable order)
   * @param seed the first frame's noise seed; each later frame the next
   */
  constructor(
    private readonly sim: SimClient,
    private readonly camera: EmulatorCamera,
    private readonly joints: () => number[],
    private readonly seed: number,
  ) {}

  /** A frame captured now, or the one being captured when this is asked. */
  frame(): Promise<PropertyBytes> {
    if (this.running) return this.running;
    const run = (this.running = this.capture().finally(() => {
      if (this.running === run) this.running = null;
    }));
    return run;
  }

  /** Removes the camera's folder (its frame file). */
  close(): void {
    rmSync(this.dir, { recursive: true, force: true });
  }

  private async capture(): Promise<PropertyBytes> {
    const c = this.camera;
    const seed = (this.seed + this.frames++) % SEEDS;
    try {
      await this.sim.setJointPositions({ robot: EMULATED_ID, positions: this.joints() });
      await this.sim.captureDepth({ file: this.file, position: c.position, target: c.target, width: c.width, height: c.height, noise: c.noise, dropout: c.dropout, seed });
    } catch (err) {
      throw fromBackendError(err);
    }
    return { contentType: POINT_CLOUD_TYPE, body: readFileSync(this.file) };
  }
}
