/** `robwot openapi`: the OpenAPI 3.0 document of a twin folder's HTTP API (`../openapi.ts`). */
import { thingOpenApi } from "../openapi.js";
import { DOCUMENT_OPTIONS_HELP, writeTwinDocument } from "./twin-document.js";

export const USAGE = `Usage: robwot openapi <twin-folder> [options]

Writes the OpenAPI 3.0 document of the twin's HTTP API: the official WoT playground converter
(@thing-description-playground/td_to_openapi) run on the folder's td.json, corrected where the
converter is wrong (complete request and response schemas, the error answers of every status the TD
lists, one server), validated against the OpenAPI 3.0 schema.

${DOCUMENT_OPTIONS_HELP}`;

export function run(argv: string[]): Promise<number> {
  return writeTwinDocument(argv, "openapi", "E_OPENAPI", "OpenAPI document", (td, base) => thingOpenApi(td, base !== undefined ? { base } : {}));
}
