/** Browser-safe public surface of @robwot/core (no node: imports). Import as `@robwot/core/browser`. */
export * from "./errors.js";
export type * from "./types.js";
export type * from "./td/types.js";
export { buildThingDescription, thingId, transformBounds, DEFAULT_BASE_URL, ROBWOT_NS, TD_CONTEXT_V11 } from "./td/build.js";
export type { BuildThingDescriptionOptions, SimilarityTransform } from "./td/build.js";
export { securityFor } from "./td/security.js";
export type { AuthScheme } from "./td/security.js";
export { thingSlug, fnv1a64, canonicalJson } from "./td/hash.js";
