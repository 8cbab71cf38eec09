/** Browser-safe public surface of @robwot/core (no node: imports). Import as `@robwot/core/browser`. */
export * from "./errors.js";
export type * from "./types.js";
export type * from "./td/types.js";
export { TWIN_FILES, TWIN_FOLDERS } from "./twin-layout.js";
export type { TwinFile } from "./twin-layout.js";
export { buildThingDescription, targetBounds, thingId, withAbsoluteForms, DEFAULT_BASE_URL, LIVE_REL, REACHABILITY_REL, THING_MODEL_FILE, THING_MODEL_TYPE, ROBWOT_NS, TD_CONTEXT_V10, TD_CONTEXT_V11, WOT_PROFILES } from "./td/build.js";
export { PROBLEM_JSON, PROBLEM_SCHEMA, PROBLEM_TYPE_BASE, problemDetails, problemTitle } from "./td/problem.js";
export type { ProblemDetails } from "./td/problem.js";
export type { BuildThingDescriptionOptions } from "./td/build.js";
export { securityFor } from "./td/security.js";
export { ACTION_ID_VARIABLE, ACTION_STATUS_SCHEMA, ACTION_STATUSES, ASYNC_ACTIONS, RESPOND_ASYNC } from "./td/async-actions.js";
export type { ActionStatusValue } from "./td/async-actions.js";
export { closeSchema, MIN_QUATERNION_NORM, MIN_SPEED, tdContact } from "./td/schemas.js";
export { buildThingModel } from "./td/thing-model.js";
export { cartesianBounds, jointLimits, linkUrl, liveUrl, slugOf, speedRange, TdError } from "./td/read.js";
export type { AffordanceLike, Bounds3, FormLike, JointLimit, LinkLike, SchemaLike, ThingDescriptionLike } from "./td/read.js";
export type { AuthScheme } from "./td/security.js";
export { thingSlug, fnv1a64, canonicalJson, MAX_SLUG_LENGTH } from "./td/hash.js";
export { parseWorkspaceCsv, writeWorkspaceCsv } from "./workspace/csv.js";
export { jsonErrorAt, snippet } from "./snippet.js";
export type { WorkspaceCloud, ParseCsvOptions } from "./workspace/csv.js";
export { parseStl, writeStl, triangleNormal } from "./workspace/stl.js";
export type { StlMesh } from "./workspace/stl.js";
export { WorkspaceMesh } from "./workspace/mesh.js";
export type { MeshTopology } from "./workspace/topology.js";
export { PointCloudIndex } from "./workspace/point-cloud.js";
export type { PointCloudScore, PointCloudCheck } from "./workspace/point-cloud.js";
export { Workspace } from "./workspace/workspace.js";
export { ReachabilityMap } from "./workspace/reachability.js";
export type { ReachabilityCheck, ReachabilityVoxel } from "./workspace/reachability.js";
export type { WorkspacePointCheck } from "./workspace/workspace.js";
export { loadWorkspaceFromUrls, reachabilityVoxel } from "./workspace/load-url.js";
export type { FetchLike } from "./workspace/load-url.js";
export * from "./geometry.js";
export { reachOverlaps, SAME_BASE, startCollision } from "./overlap.js";
export type { PlacedRobot } from "./overlap.js";
export {
  activeCalibration,
  FrameMap,
  transformBounds,
  solveCalibration,
  checkCalibration,
  applyCalibration,
  invertCalibration,
  COLLINEAR_RATIO,
  COINCIDENT_SPREAD,
  CALIBRATION_SCALE_RANGE,
  MAX_CALIBRATION_COORDINATE,
  MAX_CALIBRATION_RMS,
} from "./calibration.js";
export type { Calibration, CalibrationPair, PointLike, SimilarityTransform } from "./calibration.js";
export { gaussian, mulberry32 } from "./random.js";
export { tdCouplings, withFollowers } from "./couplings.js";
export type { TdCoupling } from "./couplings.js";
export { conveyorThingDescription, sensorThingDescription, BELT_SPEED_SCHEMA, CONVEYOR_ACTIONS, CONVEYOR_STATE_SCHEMA } from "./td/cell-things.js";
export type { CellThingOptions } from "./td/cell-things.js";
