/**
 * The servient's record of the one simulation world every twin of a `serve` shares (the backend holds the
 * world itself): the union of the twins' scenes (obstacles, objects
 * and other robots), each twin's robot (robots see each other as obstacles), and run-time scene
 * edits; objects where the backend says they rest. `restore` rebuilds it on a fresh backend (start and after a crash), putting every robot back
 * at its last known joint state; at the first, a twin whose start pose collides is warned about. Emits
 * `scene` after every run-time edit (the /live `scene` message).
 */
import { EventEmitter } from "node:events";
import { isAbsolute, join, relative, resolve, sep } from "node:path";
import { quat, quatArr, quatConj, quatMul, quatRotate, startCollision, TWIN_FILES, type Quaternion, type Vec3 } from "@robwot/core";
import type { ObjectMoveParams, ObstacleMoveParams, SceneObject as RestingObject, SimClient } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import { CellRecord } from "./cell-record.js";
import { ServientError } from "./errors.js";
import { confine } from "./static-files.js";
import type { SceneObject, SceneObstacle } from "./twin-folder.js";
import type { Twin } from "./twin.js";

/** Mesh obstacle files in scene.json are relative to the twin folder (copied there by generate). */
function withAbsoluteMesh<T extends SceneObstacle>(ob: T, dir: string): T {
  if (ob.shape.type !== "mesh" || isAbsolute(ob.shape.file)) return ob;
  return { ...ob, shape: { ...ob.shape, file: join(dir, ob.shape.file) } };
}

/** Scene-file mesh obstacles as clients see them: relative files become `/<slug>/<file>` URLs. */
function servedMeshUrl(ob: SceneObstacle, slug: string): string | null {
  if (ob.shape.type !== "mesh" || isAbsolute(ob.shape.file)) return null;
  const rel = ob.shape.file.split(/[\\/]+/).filter((p) => p !== "" && p !== ".");
  return `/${encodeURIComponent(slug)}/${rel.map(encodeURIComponent).join("/")}`;
}

/** ms between two `scene` events while a held object moves with its robot */
const HELD_SCENE_MS = 100;

export class SceneRecord extends EventEmitter<{ scene: [] }> {
  /** current obstacles by name (scene files + run-time edits), world frame */
  readonly obstacles = new Map<string, SceneObstacle>();
  /** current objects by name (scene files + run-time edits), where they rest (world frame) */
  readonly objects = new Map<string, SceneObject>();
  /** object -> the robot holding it */
  private readonly heldBy = new Map<string, string>();
  /** object -> its pose in the frame of the end effector holding it (m, quaternion), taken when it was
   *  caught: its pose in `objects` follows the robot's joints */
  private readonly heldOffset = new Map<string, { p: Vec3; q: Quaternion }>();
  private sceneTimer: NodeJS.Timeout | null = null;
  /** mesh files of scene-file obstacles and objects as URLs of the twin folder that holds them */
  private readonly meshUrls = new Map<string, string>();
  /** robots of the scene files that are not twins */
  private readonly sceneRobots: Record<string, unknown>[] = [];
  /** the conveyors (state now) and sensors of the twins' scenes, replayed with the scene (`cell-record.ts`) */
  readonly cell: CellRecord;

  /** whether the twins' start poses were checked (`warnStartCollisions`: at the first restore only) */
  private startChecked = false;

  /** folders run-time mesh obstacles may come from: the twin folders, then `--mesh-root` folders */
  readonly meshRoots: string[];

  constructor(
    private readonly twins: Twin[],
    meshRoots: readonly string[] = [],
  ) {
    super();
    this.meshRoots = [...twins.map((t) => t.folder.dir), ...meshRoots].map((d) => resolve(d));
    this.cell = new CellRecord(twins.map((t) => t.folder.scene));
    const robotKeys = new Set<string>();
    const twinIds = new Set(twins.map((t) => t.robotId));
    for (const t of twins) {
      for (const ob of t.folder.scene.obstacles ?? []) {
        if (this.obstacles.has(ob.name)) continue;
        this.obstacles.set(ob.name, withAbsoluteMesh(ob, t.folder.dir));
        const url = servedMeshUrl(ob, t.slug);
        if (url !== null) this.meshUrls.set(ob.name, url);
      }
      for (const ob of t.folder.scene.objects ?? []) {
        if (this.objects.has(ob.name)) continue;
        this.objects.set(ob.name, withAbsoluteMesh(ob, t.folder.dir));
        const url = servedMeshUrl(ob, t.slug);
        if (url !== null) this.meshUrls.set(ob.name, url);
      }
      for (const r of (t.folder.scene.robots ?? []) as Record<string, unknown>[]) {
        const key = JSON.stringify([r.id ?? null, r.urdf, r.basePosition ?? null]);
        if (robotKeys.has(key) || (typeof r.id === "string" && twinIds.has(r.id))) continue;
        robotKeys.add(key);
        this.sceneRobots.push(r);
      }
      t.on("joints", () => this.followHeld(t));
    }
  }

  /** The objects `twin` holds put where its end effector has them now; the `scene` event at most every
   *  `HELD_SCENE_MS` while they move (the last pose always told). */
  private followHeld(twin: Twin): void {
    let moved = false;
    for (const [name, by] of this.heldBy) {
      const off = this.heldOffset.get(name);
      const ob = this.objects.get(name);
      if (by !== twin.robotId || !off || !ob) continue;
      const at = quatRotate(twin.orientation, off.p);
      const position: Vec3 = [twin.position[0] + at[0], twin.position[1] + at[1], twin.position[2] + at[2]];
      this.objects.set(name, { ...ob, position, orientation: quatArr(quatMul(twin.orientation, off.q)) });
      moved = true;
    }
    if (moved && this.sceneTimer === null) {
      this.sceneTimer = setTimeout(() => {
        this.sceneTimer = null;
        this.emit("scene");
      }, HELD_SCENE_MS);
      this.sceneTimer.unref?.();
    }
  }

  /** The current obstacles in scene.json's shape (Contract 2), mesh files as URLs where they are served. */
  sceneObstacles(): SceneObstacle[] {
    return [...this.obstacles.values()].map((ob) => this.served(ob));
  }

  /** The current objects where they rest, mesh files as URLs where they are served (the `objects` property). */
  sceneObjects(): SceneObject[] {
    return [...this.objects.values()].map((ob) => {
      const by = this.heldBy.get(ob.name);
      return this.served(by === undefined ? ob : { ...ob, heldBy: by });
    });
  }

  private served<T extends SceneObstacle>(ob: T): T {
    const url = this.meshUrls.get(ob.name);
    return url === undefined || ob.shape.type !== "mesh" ? ob : { ...ob, shape: { ...ob.shape, file: url } };
  }

  /** Builds the world on a (new) backend connection. */
  readonly restore = async (sim: SimClient): Promise<void> => {
    await sim.resetWorld();
    // the scene's robots load from the twin folders (jailed): their convex parts are there, never decomposed
    const objects = [...this.objects.values()];
    await sim.loadScene({ scene: { version: 1, obstacles: [...this.obstacles.values()], objects, robots: this.sceneRobots, ...this.cell.sceneParts() }, decompose: false });
    // a fresh backend's grippers are open: what they held is an object again, settled where it was
    this.heldBy.clear();
    this.heldOffset.clear();
    if (objects.length > 0) for (const o of (await sim.listWorld()).objects) this.rested(o);
    for (const twin of this.twins) {
      const m = twin.folder.manifest.robot;
      const model = await sim.loadRobot({
        urdf: twin.folder.urdfPath,
        id: twin.robotId,
        ...(m.basePosition ? { basePosition: m.basePosition } : {}),
        ...(m.baseOrientation ? { baseOrientation: m.baseOrientation } : {}),
        ...(m.eeLink ? { eeLink: m.eeLink } : {}),
        ...(m.srdf ? { srdf: join(twin.folder.dir, m.srdf) } : {}),
        ...(m.clearance !== undefined ? { clearance: m.clearance } : {}),
        ...(m.accelerations !== undefined ? { accelerationLimits: m.accelerations } : {}),
        ...(m.jerks !== undefined ? { jerkLimits: m.jerks } : {}),
        ...(m.couplings !== undefined ? { couplings: m.couplings } : {}),
        decompose: false, // generate wrote the convex parts: serve never decomposes (refused instead)
      });
      twin.model = model;
      if (m.gripper !== undefined) {
        // a fresh backend's gripper starts open: what it held was replayed as an object where it was
        const { kind, time, capture, joints } = m.gripper;
        type Joints = Parameters<SimClient["configureGripper"]>[0]["joints"];
        await sim.configureGripper({ robot: twin.robotId, kind, time, capture, ...(joints !== undefined ? { joints: joints as Joints } : {}) });
        twin.gripper = { state: "open", holding: null, kind, time };
        twin.emit("gripper");
      }
      if (twin.q.length === 0 && m.home !== undefined) {
        // the first start: the SRDF's home pose (its joints checked against the URDF's limits by the backend)
        const home = m.home.joints;
        await sim.setJointPositions({ robot: twin.robotId, positions: model.controllable.map((j) => home[j] ?? 0) }).catch((err: unknown) => {
          throw new ServientError(400, "E_TWIN_FOLDER", `${join(twin.folder.dir, TWIN_FILES.manifest)}: robot.home (${m.home!.from}) cannot be taken: ${err instanceof Error ? err.message : String(err)}`, { folder: twin.folder.dir, file: TWIN_FILES.manifest, field: "robot.home" });
        });
      } else if (twin.q.length === model.controllable.length) {
        // best effort: if the last state cannot be restored, the loop below reads back the state the
        // backend really has, so the twin never reports joints the simulation does not hold
        await sim.setJointPositions({ robot: twin.robotId, positions: twin.q }).catch(() => undefined);
      }
    }
    for (const twin of this.twins) {
      const { positions } = await sim.getJointPositions({ robot: twin.robotId });
      twin.applyPose(positions, await sim.fk({ robot: twin.robotId, positions }));
    }
    // path checks and detour searches skip Bullet where the compiled outer bounds find states free for
    // sure: loaded in the backend's background once the world stands (verdicts are the same without them)
    await sim.planningWarmUp();
    if (!this.startChecked) await this.warnStartCollisions(sim);
  };

  /** Once, when the twins are first restored: a twin whose start pose touches something is warned about,
   * naming the bodies (its moves must first leave the contact). */
  private async warnStartCollisions(sim: SimClient): Promise<void> {
    this.startChecked = true;
    for (const twin of this.twins) {
      const { contacts } = await sim.checkCollision({ robot: twin.robotId });
      const said = startCollision(`twin ${twin.robotId}: its start pose`, contacts);
      if (said !== undefined) process.emitWarning(`robwot serve: ${said}`, { code: "ROBWOT_START_COLLIDES" });
    }
  }

  /**
   * The file of a run-time mesh obstacle: a path relative to a mesh root (first match), or an absolute
   * path inside one. Anything else is refused before the file system is asked, so the answer never tells
   * whether a file exists outside the roots.
   */
  meshFile(file: string): string {
    const rels = isAbsolute(file)
      ? this.meshRoots.map((root) => [root, relative(root, file)] as const).filter(([, rel]) => rel !== "" && !rel.startsWith("..") && !isAbsolute(rel))
      : this.meshRoots.map((root) => [root, file] as const);
    const lexicallyInside = rels.filter(([, rel]) => !rel.split(/[\\/]/).some((p) => p === ".."));
    if (lexicallyInside.length === 0) {
      throw new ServientError(403, "E_PATH_ESCAPE", `mesh files of run-time obstacles must lie in the twin folder or a --mesh-root folder (${this.meshRoots.join(", ")})`, {
        file,
        roots: this.meshRoots,
      });
    }
    for (const [root, rel] of lexicallyInside) {
      const found = confine(root, rel.split(sep).join("/"));
      if (found) return found;
    }
    throw new ServientError(404, "E_FILE_NOT_FOUND", `mesh file ${file} not found in ${lexicallyInside.map(([r]) => r).join(", ")}`, { file });
  }

  async addObstacle(backend: BackendSupervisor, input: SceneObstacle): Promise<unknown> {
    const spec = this.newBody(input);
    const out = await backend.sim.addObstacle(spec);
    this.obstacles.set(spec.name, { ...spec, ...(out ?? {}) });
    this.emit("scene");
    return out;
  }

  async moveObstacle(backend: BackendSupervisor, pose: ObstacleMoveParams): Promise<unknown> {
    const cur = this.obstacles.get(pose.name);
    if (!cur) throw this.unknown(pose.name);
    const out = await backend.sim.moveObstacle(pose);
    const next: SceneObstacle = { ...cur, position: pose.position };
    delete next.orientation;
    delete next.rpy;
    if (pose.orientation) next.orientation = pose.orientation;
    if (pose.rpy) next.rpy = pose.rpy;
    this.obstacles.set(pose.name, { ...next, ...(out ?? {}) });
    this.emit("scene");
    return out;
  }

  async removeObstacle(backend: BackendSupervisor, name: string): Promise<Record<string, never>> {
    if (!this.obstacles.has(name)) throw this.unknown(name);
    await backend.sim.removeObstacle({ name });
    this.obstacles.delete(name);
    this.meshUrls.delete(name);
    this.emit("scene");
    return {};
  }

  /** A new obstacle's or object's spec: its name free, a mesh file inside the mesh roots. */
  private newBody<T extends SceneObstacle>(input: T): T {
    if (this.obstacles.has(input.name) || this.objects.has(input.name) || this.twins.some((t) => t.robotId === input.name)) {
      throw new ServientError(409, "E_NAME_TAKEN", `an obstacle, object or robot named '${input.name}' already exists`, { name: input.name });
    }
    return input.shape.type === "mesh" ? { ...input, shape: { ...input.shape, file: this.meshFile(input.shape.file) } } : input;
  }

  async addObject(backend: BackendSupervisor, input: SceneObject): Promise<RestingObject> {
    const out = await backend.sim.addObject(this.newBody(input));
    this.rested(out);
    this.emit("scene");
    return this.served(out);
  }

  async moveObject(backend: BackendSupervisor, pose: ObjectMoveParams): Promise<RestingObject> {
    if (!this.objects.has(pose.name)) throw this.unknown(pose.name, "object");
    const out = await backend.sim.moveObject(pose);
    this.rested(out);
    this.emit("scene");
    return this.served(out);
  }

  async removeObject(backend: BackendSupervisor, name: string): Promise<Record<string, never>> {
    if (!this.objects.has(name)) throw this.unknown(name, "object");
    await backend.sim.removeObject({ name });
    this.objects.delete(name);
    this.meshUrls.delete(name);
    this.emit("scene");
    return {};
  }

  /** Whether some robot holds an object. */
  get holding(): boolean {
    return this.heldBy.size > 0;
  }

  /** The objects as the backend holds them now, those a gripper holds with `heldBy` (after a gripper
   *  closed or opened). */
  async syncObjects(backend: BackendSupervisor): Promise<void> {
    const now = (await backend.sim.listWorld()).objects;
    this.objects.clear();
    this.heldBy.clear();
    this.heldOffset.clear();
    for (const o of now) {
      this.rested(o);
      const twin = o.heldBy === undefined ? undefined : this.twins.find((t) => t.robotId === o.heldBy);
      if (twin === undefined) continue;
      this.heldBy.set(o.name, twin.robotId);
      const back = quatConj(twin.orientation);
      const rel = quatRotate(back, [o.position[0]! - twin.position[0], o.position[1]! - twin.position[1], o.position[2]! - twin.position[2]]);
      this.heldOffset.set(o.name, { p: rel, q: quatMul(back, quat(o.orientation)) });
    }
    this.emit("scene");
  }

  /** Objects a running conveyor moved (`cell.advance`'s `moved`, `cell-clock.ts`): where they are now. */
  movedByCell(moved: readonly RestingObject[]): void {
    if (moved.length === 0) return;
    for (const o of moved) if (this.objects.has(o.name)) this.rested(o);
    this.emit("scene");
  }

  /** An object where the backend says it rests (replayed there on a fresh backend). */
  private rested(o: RestingObject): void {
    const { name, shape, position, orientation, mass } = o;
    this.objects.set(name, { name, shape, position, orientation, mass, ...(o.color ? { color: o.color } : {}) });
  }

  private unknown(name: string, kind: "obstacle" | "object" = "obstacle"): ServientError {
    const known = kind === "obstacle" ? this.obstacles : this.objects;
    return new ServientError(404, "E_UNKNOWN_OBJECT", `no ${kind} named '${name}'`, { name, available: [...known.keys()] });
  }
}
