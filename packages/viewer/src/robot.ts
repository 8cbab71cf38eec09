/**
 * The robot model: URDF + meshes through urdf-loader, with mesh errors surfaced (urdf-loader's default
 * only logs them), OBJ support (pybullet_data robots use OBJ visuals), joint application and the
 * collision highlight.
 */
import { Color, LoadingManager, Material, Mesh, MeshPhongMaterial, type Object3D } from "three";
import { ColladaLoader } from "three/examples/jsm/loaders/ColladaLoader.js";
import { OBJLoader } from "three/examples/jsm/loaders/OBJLoader.js";
import { STLLoader } from "three/examples/jsm/loaders/STLLoader.js";
import URDFLoader, { type URDFLink, type URDFRobot } from "urdf-loader";
import { type TdCoupling, withFollowers } from "@robwot/core/browser";
import { ViewerError } from "./errors.js";

export interface LoadedRobot {
  robot: URDFRobot;
  /** Problems met while loading meshes (the model is still shown without those parts). */
  meshErrors: ViewerError[];
}

type Done = (mesh: Object3D, err?: Error) => void;

/** Load the URDF at `url`; resolves once every mesh has loaded or failed. */
export function loadRobot(url: string): Promise<LoadedRobot> {
  const meshErrors: ViewerError[] = [];
  return new Promise((resolve, reject) => {
    let robot: URDFRobot | null = null;
    const manager = new LoadingManager();
    // urdf-loader ends the URDF's own item after parsing, so by then every mesh item is registered and
    // onLoad fires once all of them are done. Our mesh callbacks run as promise reactions: let them
    // finish (next macrotask) before resolving.
    manager.onLoad = () =>
      window.setTimeout(() => {
        if (!robot) return;
        robot.traverse((o) => {
          if (o instanceof Mesh && o.material instanceof Material && !hasUrdfMaterial(o.material)) o.material = DEFAULT_MATERIAL;
        });
        resolve({ robot, meshErrors });
      }, 0);
    const loader = new URDFLoader(manager);
    loader.parseCollision = false;
    loader.loadMeshCb = (path: string, mgr: LoadingManager, material: Material, done: Done) => {
      // Never hand an error to urdf-loader (it would only console.error it): record it for the page.
      loadMesh(path, mgr, material).then(
        (obj) => done(obj),
        (err: unknown) =>
          meshErrors.push(
            new ViewerError("E_MESH", `cannot load mesh ${path}: ${errText(err)}`, { file: path, urdf: url }),
          ),
      );
    };
    loader.load(
      url,
      (r) => (robot = r),
      undefined,
      (err: unknown) => reject(new ViewerError("E_URDF", `cannot load URDF ${url}: ${errText(err)}`, { file: url })),
    );
  });
}

/** Visuals (meshes and primitives) without a URDF <material> get a neutral grey, not urdf-loader's plain white. */
const DEFAULT_MATERIAL = new MeshPhongMaterial({ color: 0xb8bec8, specular: 0x333333, shininess: 40 });

function hasUrdfMaterial(m: Material): boolean {
  return !(m instanceof MeshPhongMaterial && m.name === "" && m.color.getHex() === 0xffffff && m.map === null);
}

async function loadMesh(path: string, manager: LoadingManager, material: Material): Promise<Object3D> {
  if (/\.stl$/i.test(path)) {
    const geometry = await new STLLoader(manager).loadAsync(path);
    return new Mesh(geometry, material);
  }
  if (/\.obj$/i.test(path)) {
    const group = await new OBJLoader(manager).loadAsync(path);
    group.traverse((o) => {
      if (o instanceof Mesh) o.material = material;
    });
    return group;
  }
  if (/\.dae$/i.test(path)) {
    const dae = await new ColladaLoader(manager).loadAsync(path);
    return dae.scene;
  }
  throw new ViewerError("E_MESH_FORMAT", `no loader for mesh ${path} (supported: .stl, .obj, .dae)`, { file: path });
}

function errText(err: unknown): string {
  if (err instanceof Error) return err.message;
  if (err instanceof ProgressEvent && err.target instanceof XMLHttpRequest) return `HTTP ${err.target.status}`;
  return String(err);
}

/** Apply joint values, and each follower's from its `couplings` (names unknown to the model are reported
 * back, not ignored silently). */
export function applyJoints(robot: URDFRobot, joints: Record<string, number>, couplings: readonly TdCoupling[] = []): string[] {
  const unknown: string[] = [];
  for (const [name, value] of Object.entries(withFollowers(joints, couplings))) {
    const joint = robot.joints[name];
    if (joint) joint.setJointValue(value);
    else unknown.push(name);
  }
  return unknown;
}

const HIGHLIGHT = new MeshPhongMaterial({ color: new Color(0xe02020), emissive: new Color(0x600000) });

/** Colour a link's own visuals red (not its child links) for `ms` milliseconds. */
export function highlightLink(link: URDFLink, ms: number): void {
  const meshes: Mesh[] = [];
  const visit = (o: Object3D): void => {
    for (const child of o.children) {
      if ((child as Partial<URDFLink>).isURDFLink || "isURDFJoint" in child) continue;
      if (child instanceof Mesh) meshes.push(child);
      visit(child);
    }
  };
  visit(link);
  const saved = meshes.map((m) => m.material);
  for (const m of meshes) m.material = HIGHLIGHT;
  window.setTimeout(() => meshes.forEach((m, i) => (m.material = saved[i] ?? m.material)), ms);
}
