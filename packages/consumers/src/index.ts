/**
 * Public surface of @robwot/consumers: the helpers the scenarios are built from. The scenarios
 * themselves are scripts (`dist/<name>.js`), not exports: importing one would run it.
 */
export { openSession, read, invoke, defaultTdUrl, authFromEnv, authHeaders, DEMO_SLUG, DEFAULT_TD_URL, ActionError } from "./lib/connect.js";
export type { Session, Twin, Auth } from "./lib/connect.js";
export { subscribeLive, resolveLiveUrl } from "./lib/live.js";
export type { LiveMessage, LiveSubscription } from "./lib/live.js";
export { jointLimits, cartesianBounds, linkUrl, liveUrl, slugOf, TdError } from "@robwot/core";
export type { JointLimit, ThingDescriptionLike } from "@robwot/core";
export { spreadTargets, acceptedTargets, maxAbsDiff } from "./lib/targets.js";
export { loadNodeWot } from "./lib/node-wot.js";
