/** Builds the twin's Thing Description with `@robwot/core` and validates it with the official validator. */
import { type BuildThingDescriptionOptions, buildThingDescription, canonicalJson, fnv1a64, type ThingDescription, validateThingDescription } from "@robwot/core";
import type { RobotModel, WorkspaceSummary } from "./backend.js";

export interface BuiltTd {
  td: ThingDescription;
  /** Errors of the official validator (empty when valid). */
  validate(): Promise<string[]>;
}

export function buildTd(model: RobotModel, summary: WorkspaceSummary, scene: unknown, baseUrl: string, tool?: BuildThingDescriptionOptions["tool"]): BuiltTd {
  const td = buildThingDescription({ model, summary, baseUrl, sceneId: fnv1a64(canonicalJson(scene)), srdf: model.srdf !== undefined, ...(tool ? { tool } : {}) });
  return {
    td,
    async validate() {
      const result = await validateThingDescription(td);
      return result.valid ? [] : result.errors.length > 0 ? result.errors : ["rejected by the validator"];
    },
  };
}

export function tdErrorsMessage(errors: string[]): string {
  return errors.slice(0, 5).join("; ") + (errors.length > 5 ? ` (and ${errors.length - 5} more)` : "");
}
