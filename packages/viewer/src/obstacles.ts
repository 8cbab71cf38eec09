/**
 * Scene obstacles and objects from `scene.json` or a /live `scene` message (Contract 2; shapes as in
 * Contract 1; objects at the pose where they rest), built in URDF world coordinates (Z up) for `worldRoot`.
 */
import {
  BoxGeometry,
  CylinderGeometry,
  type BufferGeometry,
  Group,
  Mesh,
  MeshPhongMaterial,
  SphereGeometry,
} from "three";
import { STLLoader } from "three/examples/jsm/loaders/STLLoader.js";
import { OBJLoader } from "three/examples/jsm/loaders/OBJLoader.js";
import { ViewerError } from "./errors.js";
import { rpyToQuaternion, xyzwToQuaternion, type Vec3 } from "./three-frames.js";
import { fetchBuffer, fetchText, isRecord } from "./http.js";

const MATERIAL = new MeshPhongMaterial({ color: 0x8d99ae, specular: 0x222222, shininess: 20 });
/** an object without a colour of its own: apart from the grey obstacles */
const OBJECT_COLOUR = 0xe07a1f;

type Kind = "obstacles" | "objects";

export interface BuiltObstacles {
  group: Group;
  /** the obstacles' names */
  names: string[];
  /** each object's position (m, world frame) as drawn */
  objects: Record<string, number[]>;
  errors: ViewerError[];
}

export async function buildObstacles(scene: unknown, base: string): Promise<BuiltObstacles> {
  const group = new Group();
  group.name = "obstacles";
  const errors: ViewerError[] = [];
  const list = (kind: Kind): [unknown, Kind, number][] =>
    isRecord(scene) && Array.isArray(scene[kind]) ? (scene[kind] as unknown[]).map((s, i): [unknown, Kind, number] => [s, kind, i]) : [];
  // a conveyor's belt is drawn as the box obstacle it is (scene.json and /live list it as a conveyor)
  const conveyors = isRecord(scene) && Array.isArray(scene["conveyors"]) ? (scene["conveyors"] as unknown[]) : [];
  const belts = conveyors.map((c, i): [unknown, Kind, number] => [isRecord(c) ? { ...c, shape: { type: "box", size: c["size"] } } : c, "obstacles", i]);
  const meshes = await Promise.all(
    [...list("obstacles"), ...belts, ...list("objects")].map(async ([spec, kind, i]) => {
      try {
        return await buildOne(spec, base, i, kind);
      } catch (err) {
        errors.push(err instanceof ViewerError ? err : new ViewerError("E_SCENE", String(err), { path: `/${kind}/${i}` }));
        return null;
      }
    }),
  );
  // in the scene's order, whatever order the mesh files arrived in
  const built = meshes.filter((m): m is Mesh => m !== null);
  for (const m of built) group.add(m);
  const objects = built.filter((m) => m.userData["kind"] === "objects").map((m) => [m.name, m.position.toArray()] as const);
  return { group, names: built.filter((m) => m.userData["kind"] === "obstacles").map((m) => m.name), objects: Object.fromEntries(objects), errors };
}

async function buildOne(spec: unknown, base: string, index: number, kind: Kind): Promise<Mesh> {
  if (!isRecord(spec) || !isRecord(spec["shape"])) {
    throw new ViewerError("E_SCENE", `${kind === "objects" ? "object" : "obstacle"} #${index} has no shape`, { path: `/${kind}/${index}` });
  }
  const name = typeof spec["name"] === "string" ? spec["name"] : `${kind}-${index}`;
  const material = MATERIAL.clone();
  if (kind === "objects") material.color.setHex(OBJECT_COLOUR);
  const colour = spec["color"];
  if (Array.isArray(colour) && colour.length >= 3 && colour.every((c) => typeof c === "number")) {
    material.color.setRGB(colour[0] as number, colour[1] as number, colour[2] as number);
    if (typeof colour[3] === "number" && colour[3] < 1) {
      material.transparent = true;
      material.opacity = colour[3];
    }
  }
  const mesh = new Mesh(await geometry(spec["shape"], base, name), material);
  mesh.name = name;
  mesh.userData["kind"] = kind;
  const pos = vec3(spec["position"]) ?? [0, 0, 0];
  mesh.position.set(pos[0], pos[1], pos[2]);
  const q = quat(spec["orientation"]);
  const rpy = vec3(spec["rpy"]);
  if (q) mesh.quaternion.copy(xyzwToQuaternion(q));
  else if (rpy) mesh.quaternion.copy(rpyToQuaternion(rpy));
  return mesh;
}

async function geometry(shape: Record<string, unknown>, base: string, name: string): Promise<BufferGeometry> {
  const num = (k: string): number => {
    const v = shape[k];
    if (typeof v !== "number" || !Number.isFinite(v) || v <= 0) {
      throw new ViewerError("E_SCENE", `obstacle ${name}: shape.${k} must be a positive number`, { name, got: v });
    }
    return v;
  };
  switch (shape["type"]) {
    case "box": {
      const s = vec3(shape["size"]);
      if (!s) throw new ViewerError("E_SCENE", `obstacle ${name}: box needs size [x,y,z]`, { name });
      return new BoxGeometry(s[0], s[1], s[2]);
    }
    case "sphere":
      return new SphereGeometry(num("radius"), 32, 16);
    case "cylinder":
      // three's cylinder axis is its local Y; URDF/PyBullet cylinders are along local Z.
      return new CylinderGeometry(num("radius"), num("radius"), num("length"), 32).rotateX(Math.PI / 2);
    case "mesh":
      return meshGeometry(shape, base, name);
    default:
      throw new ViewerError("E_SCENE", `obstacle ${name}: unknown shape type ${String(shape["type"])}`, {
        name,
        expected: ["box", "sphere", "cylinder", "mesh"],
      });
  }
}

async function meshGeometry(shape: Record<string, unknown>, base: string, name: string): Promise<BufferGeometry> {
  const file = shape["file"];
  if (typeof file !== "string") throw new ViewerError("E_SCENE", `obstacle ${name}: mesh needs file`, { name });
  const url = new URL(file, base).href;
  let geom: BufferGeometry;
  if (/\.stl$/i.test(file)) geom = new STLLoader().parse(await fetchBuffer(url));
  else if (/\.obj$/i.test(file)) {
    const group = new OBJLoader().parse(await fetchText(url));
    const first = group.children.find((c): c is Mesh => c instanceof Mesh);
    if (!first) throw new ViewerError("E_SCENE", `obstacle ${name}: ${file} has no mesh`, { name, file });
    geom = first.geometry;
  } else throw new ViewerError("E_SCENE", `obstacle ${name}: unsupported mesh ${file} (.stl, .obj)`, { name, file });
  const sc = shape["scale"];
  const s = typeof sc === "number" ? ([sc, sc, sc] as const) : vec3(sc);
  if (s) geom.scale(s[0], s[1], s[2]);
  return geom;
}

function vec3(v: unknown): Vec3 | null {
  if (Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === "number")) return [v[0] as number, v[1] as number, v[2] as number];
  if (isRecord(v) && ["x", "y", "z"].every((k) => typeof v[k] === "number")) {
    return [v["x"] as number, v["y"] as number, v["z"] as number];
  }
  return null;
}

function quat(v: unknown): readonly [number, number, number, number] | null {
  if (Array.isArray(v) && v.length === 4 && v.every((x) => typeof x === "number")) {
    return [v[0] as number, v[1] as number, v[2] as number, v[3] as number];
  }
  if (isRecord(v) && ["x", "y", "z", "w"].every((k) => typeof v[k] === "number")) {
    return [v["x"] as number, v["y"] as number, v["z"] as number, v["w"] as number];
  }
  return null;
}
