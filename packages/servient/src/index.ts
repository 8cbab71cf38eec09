/** Public surface of @robwot/servient. */
export { startServient } from "./servient.js";
export type { RunningServient, ServientOptions, ThingInfo } from "./servient.js";
export type { AuthConfig } from "./auth.js";
export { ServientError } from "./errors.js";
export { FOLLOW_RATE } from "./follow.js";
export type { LiveJoints } from "./twin.js";
