/** Public surface of @robwot/core (Node). The browser entry `./browser.js` holds the pure subset. */
export * from "./browser.js";
export { compileTdSchemas, loadTdValidator, validateThingDescription, validateThingModel } from "./td/validate.js";
export type { TdValidationResult } from "./td/validate.js";
export { loadWorkspace } from "./workspace/load-fs.js";
export { jailFile, realFolder } from "./folder-jail.js";
export type { JailVerdict } from "./folder-jail.js";
