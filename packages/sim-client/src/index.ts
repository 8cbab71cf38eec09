export { RpcConnection } from "./rpc-connection.js";
export type { CallOptions, NotificationListener, RpcConnectionOptions } from "./rpc-connection.js";
export { LONG_METHODS, SimClient } from "./sim-client.js";
export type { RpcCaller } from "./sim-client.js";
export { connect, deadlineFromEnv, defaultPython, launchBackend, LaunchedBackend, resolvePython } from "./launcher.js";
export type { BackendEvents, ExitInfo, LaunchOptions } from "./launcher.js";
export { spawnBackend, SpawnedBackend } from "./spawn.js";
export type { SpawnOptions } from "./spawn.js";
export { BackendDownError, BackendStartError, ConnectionClosedError, isRpcError, RpcError, RpcTimeoutError } from "./errors.js";
export { BackendSupervisor, DEFAULT_DEADLINES } from "./supervisor.js";
export type { Deadlines, SimConnector, SimSession, SupervisorEvents, SupervisorOptions } from "./supervisor.js";
export { describeExit, launchConnector, urlConnector } from "./connectors.js";
export { startHeartbeat } from "./heartbeat.js";
export type { HeartbeatOptions } from "./heartbeat.js";
export type { RpcErrorData } from "./errors.js";
/** the backend contract's types (generated into core, which every package already depends on) */
export type * from "@robwot/core/backend-contract";
