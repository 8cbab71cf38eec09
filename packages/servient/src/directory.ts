/**
 * Discovery (W3C WoT Discovery 1.0): the servient introduces itself at the well-known URI and is a Thing
 * Description Directory of the Things it serves, read-only.
 *
 * - `GET /.well-known/wot`: the directory's own TD (`@type: ThingDirectory`), the introduction a
 *   discovery client starts from.
 * - `GET /things`: the listing, every served TD sorted by `id` in code point order, as a JSON array
 *   (`application/ld+json`), or `format=collection` for a `ThingCollection`. `limit` pages it: a `next` Link
 *   header carrying the same `limit` and the `offset` of the next page, and on every paged answer a
 *   `canonical` Link header with an `etag` of the collection's ids.
 * - `GET /things/{id}`: one TD (`application/td+json`), 404 as problem details when no served Thing has it.
 *
 * The write operations (create, update, delete) are not offered: the servient's Things are its twin
 * folders. The routes sit behind the same Host/Origin checks and authentication as every other one.
 */
import { createHash } from "node:crypto";
import type { IncomingMessage, ServerResponse } from "node:http";
import { PROBLEM_JSON, securityFor, TD_CONTEXT_V10, TD_CONTEXT_V11, type ThingDescription, WOT_PROFILES } from "@robwot/core";
import type { AuthConfig } from "./auth.js";
import { servientError } from "./errors.js";
import type { TdDocument } from "./twin-folder.js";

export const WELL_KNOWN_WOT = "/.well-known/wot";
export const THINGS_PATH = "/things";
const DISCOVERY_CONTEXT = "https://www.w3.org/2022/wot/discovery";
const TD_JSON = "application/td+json";
const LD_JSON = "application/ld+json";

/** What the directory lists: the served TDs (the same documents `GET /<slug>` answers). */
export interface DirectoryEnv {
  /** the servient's base URL, e.g. http://127.0.0.1:8080 */
  url(): string;
  tds(): Record<string, unknown>[];
  auth?: AuthConfig | undefined;
}

/** The directory's own TD: the `things` property (listing) and the `retrieveThing` action (by id). */
export function directoryTd(env: DirectoryEnv): TdDocument {
  const base = env.url();
  const td = {
    // the TD 1.0 URL first, as the twins' TDs: WoT runtimes that validate against TD 1.0 (node-wot 0.9.2) refuse others
    "@context": [TD_CONTEXT_V10, TD_CONTEXT_V11, DISCOVERY_CONTEXT],
    "@type": "ThingDirectory",
    id: `${base}${WELL_KNOWN_WOT}`,
    title: "RobWoT Thing Description Directory",
    description: "The robot twins this servient serves, read-only (W3C WoT Discovery: listing and retrieval)",
    base: `${base}/`,
    profile: [WOT_PROFILES[0]],
    securityDefinitions: { nosec_sc: { scheme: "nosec" } },
    security: "nosec_sc",
    properties: {
      things: {
        description: "The served Thing Descriptions, sorted by id; format=collection answers a ThingCollection",
        readOnly: true,
        oneOf: [
          { type: "array", items: { type: "object", description: "Thing Description" } },
          {
            type: "object",
            properties: {
              "@context": { const: DISCOVERY_CONTEXT },
              "@type": { const: "ThingCollection" },
              "@id": { type: "string" },
              members: { type: "array", items: { type: "object" } },
              total: { type: "integer", minimum: 0 },
              next: { type: "string" },
            },
          },
        ],
        uriVariables: {
          offset: { title: "Number of TDs to skip before the page", type: "integer", minimum: 0, default: 0 },
          limit: { title: "Number of TDs in a page", type: "integer", minimum: 1 },
          format: { title: "Payload format", type: "string", enum: ["array", "collection"], default: "array" },
        },
        forms: [
          {
            op: ["readproperty"],
            href: "things{?offset,limit,format}",
            "htv:methodName": "GET",
            contentType: LD_JSON,
            response: { contentType: LD_JSON, "htv:headers": [{ "htv:fieldName": "Link" }] },
            additionalResponses: [{ success: false, contentType: PROBLEM_JSON, description: "invalid query arguments (400)" }],
          },
        ],
      },
    },
    actions: {
      retrieveThing: {
        description: "Retrieve a Thing Description by its id",
        uriVariables: { id: { "@type": "ThingID", title: "Thing Description ID", type: "string", format: "iri-reference" } },
        output: { description: "The Thing Description", type: "object" },
        safe: true,
        idempotent: true,
        synchronous: true,
        forms: [
          {
            op: ["invokeaction"],
            href: "things/{id}",
            "htv:methodName": "GET",
            contentType: TD_JSON,
            response: { contentType: TD_JSON },
            additionalResponses: [{ success: false, contentType: PROBLEM_JSON, description: "no Thing with this id (404)" }],
          },
        ],
      },
    },
  };
  return securityFor(td as unknown as ThingDescription, env.auth ? { scheme: env.auth.scheme } : null) as unknown as TdDocument;
}

/** A non-negative integer query argument, or a 400 naming it. */
function integerArg(params: URLSearchParams, name: string, minimum: number): number | undefined {
  const raw = params.get(name);
  if (raw === null) return undefined;
  const n = Number(raw);
  if (raw.trim() === "" || !Number.isSafeInteger(n) || n < minimum) {
    throw servientError("E_BAD_INPUT", `${THINGS_PATH}: ${name} must be an integer >= ${minimum} (got "${raw.slice(0, 40)}")`, { param: name });
  }
  return n;
}

function send(req: IncomingMessage, res: ServerResponse, type: string, body: unknown, headers: Record<string, string | string[]> = {}): void {
  const text = JSON.stringify(body);
  res.writeHead(200, { "Content-Type": type, "Content-Length": Buffer.byteLength(text), ...headers });
  res.end(req.method === "HEAD" ? undefined : text);
}

/** The paths `directoryRoute` answers; no twin may take their first segment as its slug. */
export function isDirectoryPath(path: string): boolean {
  return path === WELL_KNOWN_WOT || path === THINGS_PATH || path.startsWith(`${THINGS_PATH}/`);
}
export const DIRECTORY_SEGMENTS = [".well-known", THINGS_PATH.slice(1)] as const;

/**
 * Answers a GET/HEAD of the introduction or the directory (`isDirectoryPath`). Errors are thrown as
 * `ServientError` (problem details by the middleware).
 */
export function directoryRoute(req: IncomingMessage, res: ServerResponse, path: string, query: URLSearchParams, env: DirectoryEnv): void {
  if (path === WELL_KNOWN_WOT) return send(req, res, TD_JSON, directoryTd(env));
  // code point order of the ids (not localeCompare: the listing order is the spec's)
  const tds = env.tds().sort((a, b) => (String(a["id"]) < String(b["id"]) ? -1 : String(a["id"]) > String(b["id"]) ? 1 : 0));
  if (path.startsWith(`${THINGS_PATH}/`)) {
    const id = path.slice(THINGS_PATH.length + 1);
    const td = tds.find((t) => t["id"] === id);
    if (!td) throw servientError("E_NOT_FOUND", `no Thing Description with id "${id.slice(0, 200)}" here (GET ${THINGS_PATH} lists them)`, { id: id.slice(0, 200) });
    return send(req, res, TD_JSON, td);
  }
  const offset = integerArg(query, "offset", 0) ?? 0;
  const limit = integerArg(query, "limit", 1);
  const format = query.get("format") ?? "array";
  if (format !== "array" && format !== "collection") {
    throw servientError("E_BAD_INPUT", `${THINGS_PATH}: format must be "array" or "collection" (got "${format.slice(0, 40)}")`, { param: "format" });
  }
  const page = tds.slice(offset, limit === undefined ? undefined : offset + limit);
  const nextOffset = offset + page.length;
  const link = (o: number, l: number): string => `${THINGS_PATH}?offset=${o}&limit=${l}${format === "collection" ? "&format=collection" : ""}`;
  const next = limit !== undefined && nextOffset < tds.length ? link(nextOffset, limit) : null;
  const headers: Record<string, string[]> = { Link: [] };
  if (next) headers.Link!.push(`<${next}>; rel="next"`);
  if (limit !== undefined) {
    const etag = createHash("sha256").update(tds.map((t) => String(t["id"])).join("\n")).digest("hex").slice(0, 16);
    headers.Link!.push(`<${THINGS_PATH}>; rel="canonical"; etag="${etag}"`);
  }
  if (headers.Link!.length === 0) delete headers.Link;
  if (format === "array") return send(req, res, LD_JSON, page, headers);
  const collection = {
    "@context": DISCOVERY_CONTEXT,
    "@type": "ThingCollection",
    "@id": limit !== undefined ? link(offset, limit) : THINGS_PATH,
    members: page,
    total: tds.length,
    ...(next ? { next } : {}),
  };
  send(req, res, LD_JSON, collection, headers);
}
