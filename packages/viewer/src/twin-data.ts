/**
 * Loading the twin's linked data into the stage: base pose (twin.json), scene obstacles, point cloud,
 * workspace surface and reachability heat map. Each adds its layer toggle and debug counters; failures reject for the caller to show.
 */
import type { Object3D } from "three";
import { TWIN_FILES } from "@robwot/core/browser";
import { debugState, publishDebug } from "./debug.js";
import { ViewerError } from "./errors.js";
import type { QuatXyzw, Vec3 } from "./three-frames.js";
import { fetchBuffer, fetchJson, fetchText, isRecord } from "./http.js";
import type { MotionPanel } from "./motion-panel.js";
import type { ObstacleLayer } from "./scene-layer.js";
import { buildPointCloud, parseWorkspaceCsv } from "./pointcloud.js";
import { buildHeatMap } from "./reachability-layer.js";
import type { Stage } from "./stage.js";
import type { TwinTd } from "./td.js";
import { buildWorkspaceMesh, triangleCount } from "./workspace-mesh.js";

/** The robot's base pose in the world (twin.json, Contract 2), applied in URDF coordinates. */
export async function loadBasePose(td: TwinTd): Promise<{ position: Vec3; orientation: QuatXyzw }> {
  const url = new URL(TWIN_FILES.manifest, td.base).href;
  const manifest = await fetchJson(url);
  const robot = isRecord(manifest) && isRecord(manifest["robot"]) ? manifest["robot"] : {};
  const p = robot["basePosition"] ?? [0, 0, 0];
  const q = robot["baseOrientation"] ?? [0, 0, 0, 1];
  const nums = (v: unknown, n: number): v is number[] =>
    Array.isArray(v) && v.length === n && v.every((x) => typeof x === "number" && Number.isFinite(x));
  if (!nums(p, 3) || !nums(q, 4)) {
    throw new ViewerError("E_TWIN_JSON", `${url}: robot.basePosition must be [x,y,z] and robot.baseOrientation [x,y,z,w]`, {
      file: url,
      basePosition: p,
      baseOrientation: q,
    });
  }
  return { position: [p[0] as number, p[1] as number, p[2] as number], orientation: [q[0] as number, q[1] as number, q[2] as number, q[3] as number] };
}

export async function loadScene(td: TwinTd, layer: ObstacleLayer): Promise<void> {
  if (!td.links.scene) return;
  await layer.show(await fetchJson(td.links.scene), false);
}

export async function loadCloud(td: TwinTd, stage: Stage, motion: MotionPanel): Promise<Object3D | null> {
  if (!td.links.pointCloud) return null;
  const cloud = parseWorkspaceCsv(await fetchText(td.links.pointCloud), undefined, td.links.pointCloud);
  const points = buildPointCloud(cloud);
  stage.add(points);
  debugState.pointCloud = { shown: cloud.free.length, total: cloud.total, collisionFree: cloud.collisionFree };
  const label = cloud.free.length < cloud.total ? `point cloud (${cloud.free.length} of ${cloud.total})` : `point cloud (${cloud.total})`;
  motion.addLayer(label, true, (v) => stage.setVisible(points, v));
  return points;
}

export async function loadSurface(td: TwinTd, stage: Stage, motion: MotionPanel): Promise<Object3D | null> {
  if (!td.links.workspace) return null;
  const mesh = buildWorkspaceMesh(await fetchBuffer(td.links.workspace));
  stage.add(mesh);
  debugState.workspaceTriangles = triangleCount(mesh);
  motion.addLayer("workspace surface", true, (v) => stage.setVisible(mesh, v));
  return mesh;
}

/** The reachability heat map (hidden until toggled); twins generated before the map have no link. */
export async function loadReachability(td: TwinTd, stage: Stage, motion: MotionPanel): Promise<Object3D | null> {
  const { reachability, summary } = td.links;
  if (!reachability || !summary) return null;
  const [csv, json] = await Promise.all([fetchText(reachability), fetchText(summary)]);
  const heat = buildHeatMap(csv, json, { csv: reachability, summary });
  stage.add(heat.points);
  stage.setVisible(heat.points, false);
  debugState.reachability = { voxels: heat.voxels, shown: heat.shown, maxIndex: heat.maxIndex, visible: false };
  motion.addLayer(`reachability map (${heat.shown} voxels)`, false, (v) => {
    stage.setVisible(heat.points, v);
    debugState.reachability = { ...debugState.reachability!, visible: v };
    publishDebug();
  });
  return heat.points;
}
