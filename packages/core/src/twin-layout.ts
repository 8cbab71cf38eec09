/**
 * The twin folder's layout (ARCHITECTURE.md, Contract 2): the one place naming its files and folders,
 * relative to the folder. Browser-safe. The Python backend names the same files in
 * `sim-backend/src/robwot_sim/twin_layout.py`; `sim-backend/tests/test_twin_layout.py` fails when the two
 * differ.
 */
export const TWIN_FILES = Object.freeze({
  /** Thing Description (TD 1.1) */
  td: "td.json",
  /** the manifest: robot (URDF, SRDF, end-effector link, base pose), scene, generator */
  manifest: "twin.json",
  /** self-contained URDF, mesh filenames relative to the folder */
  urdf: "robot.urdf",
  /** the robot's SRDF (present when generated with one) */
  srdf: "robot.srdf",
  /** the scene used (obstacles and other robots) */
  scene: "scene.json",
  /** the labelled point cloud */
  pointCloud: "workspace.csv",
  /** the workspace surface (binary STL) */
  surface: "workspace.stl",
  /** the WorkspaceSummary */
  summary: "workspace.json",
  /** the reachability map */
  reachability: "reachability.csv",
  /** the active calibration (written by serve's calibrate) */
  calibration: "calibration.json",
  /** the Thing Model every TD links with `rel: "type"` */
  thingModel: "robot-arm.tm.json",
} as const);

export const TWIN_FOLDERS = Object.freeze({
  /** meshes copied from the robot's source (the URDF's relative mesh filenames point here) */
  meshes: "meshes",
  /** the scene's mesh obstacles, below `meshes` */
  sceneMeshes: "meshes/scene",
  /** cached convex parts of concave collision meshes, one folder per mesh key */
  collision: "collision",
  /** the scene's other robots, one exported folder each (`robots/<id>/robot.urdf`, its meshes and parts) */
  sceneRobots: "robots",
} as const);

export type TwinFile = (typeof TWIN_FILES)[keyof typeof TWIN_FILES];
