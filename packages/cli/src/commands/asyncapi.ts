/** `robwot asyncapi`: the AsyncAPI 3.0 document of a twin folder's streams (`../asyncapi.ts`). */
import { thingAsyncApi } from "../asyncapi.js";
import { placeTd } from "../td.js";
import { DOCUMENT_OPTIONS_HELP, writeTwinDocument } from "./twin-document.js";

export const USAGE = `Usage: robwot asyncapi <twin-folder> [options]

Writes the AsyncAPI 3.0 document of the twin's streams: the /live WebSocket (subscribe, resume, and the
joints, status, scene, event and physical messages) and every Server-Sent Events stream of its TD, with
the TD's data schemas as payloads; validated by the official AsyncAPI parser.

${DOCUMENT_OPTIONS_HELP}`;

export function run(argv: string[]): Promise<number> {
  return writeTwinDocument(argv, "asyncapi", "E_ASYNCAPI", "AsyncAPI document", (td, base) => thingAsyncApi(placeTd(td, base ?? String(td["base"] ?? ""))));
}
