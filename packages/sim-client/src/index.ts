export { RpcConnection } from "./rpc-connection.js";
export type { CallOptions, NotificationListener, RpcConnectionOptions } from "./rpc-connection.js";
export { SimClient } from "./sim-client.js";
export type {
  CheckPathParams,
  GenerateOptions,
  GenerateWorkspaceParams,
  IkParams,
  LoadRobotParams,
  LoadSceneParams,
  MoveParams,
  ObstaclePose,
} from "./sim-client.js";
export { connect, deadlineFromEnv, defaultPython, launchBackend, LaunchedBackend, resolvePython } from "./launcher.js";
export type { BackendEvents, ExitInfo, LaunchOptions } from "./launcher.js";
export { BackendStartError, ConnectionClosedError, isRpcError, RpcError, RpcTimeoutError } from "./errors.js";
export type { RpcErrorData } from "./errors.js";
export type * from "./types.js";
