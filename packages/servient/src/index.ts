/** Public surface of @robwot/servient. */
export { startServient } from "./servient.js";
export type { DeviceInfo, RunningServient, ServientOptions, ThingInfo } from "./servient.js";
export { AsDeviceError } from "./as-device.js";
export type { AsDeviceSpec } from "./as-device.js";
export type { AuthConfig } from "./auth.js";
export { ServientError } from "./errors.js";
export { DIVERGENCE_BOUND, FOLLOW_RATE, MONITOR_HORIZON } from "./follow.js";
export type { MonitorMode } from "./follow.js";
export { startEmulator } from "./emulate.js";
export { loadTwinFolder, robotLoadParams } from "./twin-folder.js";
export type { TwinFolder } from "./twin-folder.js";
export { loadRelayMap, RelayMapError } from "./relay-map.js";
export type { RelayMap } from "./relay-map.js";
export type { EmulatorOptions, RunningEmulator } from "./emulate.js";
export type { LiveJoints } from "./twin.js";
export type { CellDeviceInfo } from "./cell-things.js";
export type { ScanSourceOptions, ScanStatus } from "./scan-source.js";
