/**
 * The servient's router, in front of node-wot (HttpServer `middleware` option). Every request passes the
 * guards first (`RobWoT-Hop` loop 508, Host 421, Origin 403, CORS, auth 401); then the route table:
 * `/robwot.json`; the directory (`directory.ts`); the viewer at `/viewer/`; the TDs at `/` and `/<slug>`
 * (with the real base, live URL and security); the twin folder files at `/<slug>/...`; property reads and
 * action invocations (`affordance-routes.ts`: an action body read once, at most `MAX_BODY`, parsed and
 * validated against the TD, 415/413/400) and their asynchronous ActionStatus resources (`action-status.ts`);
 * SSE streams (`sse.ts`). Only the long-poll observe and event routes of a served slug reach node-wot. Every
 * error answer is RFC 7807 problem details with the error's own status (`errors.ts`), written here once;
 * anything else answers 404/405 problem details.
 */
import type { IncomingMessage, ServerResponse } from "node:http";
import { ASYNC_ACTIONS, RESPOND_ASYNC } from "@robwot/core";
import { actionStatusRoute, preferences, respondAsync, type ActionStatusStore } from "./action-status.js";
import { invokeAction, readProperty, writeProperty, type Affordances } from "./affordance-routes.js";
import { challenge, isAuthorized, type AuthConfig } from "./auth.js";
import { type DirectoryEnv, directoryRoute, isDirectoryPath } from "./directory.js";
import { toServientError, sendProblem, ServientError, servientError } from "./errors.js";
import { parseBody, validateInput } from "./input-validation.js";
import { HOP_HEADER } from "./outbound.js";
import { isJsonMediaType, RequestGuard } from "./request-guard.js";
import { confine, isTwinFile, notFound, sendFile, sendJson } from "./static-files.js";
import { SseChannel, streamSse, type SseSource } from "./sse.js";

/** Bytes an HTTP request body may have (413 past it); the emulator's cap too. */
export const MAX_BODY = 1 << 20;
/** URL segment after `/<slug>/` → affordance kind named in a 404 */
const AFFORDANCE_KINDS: Record<string, string> = { properties: "property", actions: "action", events: "event" };

export interface ServedThing {
  slug: string;
  dir: string;
  urdfName: string;
  /** the TD as served (real base, live URL, security, calibrated bounds) */
  td(): Record<string, unknown>;
  /** current input schema of an action (undefined: no input), null: no such action */
  actionInput(name: string): object | undefined | null;
  /** the SSE source of an observable property or an event, null when there is none */
  observe(kind: "properties" | "events", name: string): SseSource | null;
  /** property readers and action handlers, by name (`affordance-routes.ts`) */
  affordances: Affordances;
  /** their ActionStatus resources */
  statuses: ActionStatusStore;
}

export interface MiddlewareEnv {
  auth?: AuthConfig | undefined;
  /** Host, Origin and CORS policy */
  guard: RequestGuard;
  /** by slug (the one route of each Thing) */
  things: Map<string, ServedThing>;
  viewerDir: string | null;
  index(): unknown;
  /** `/.well-known/wot` and the read-only Thing Description Directory (`directory.ts`) */
  directory: DirectoryEnv;
  /** this servient's own `RobWoT-Hop` token (`outbound.ts`): a request carrying it is a loop (508) */
  hop?: string;
}

const READ = ["GET", "HEAD"] as const;
/** An ActionStatus resource: queryaction (GET), cancelaction (DELETE) */
const STATUS = ["GET", "DELETE"] as const;

/** Methods of node-wot's affordance routes under `/<slug>/...` (null: no such route, 404). Only these
 *  reach node-wot, each after the checks of its kind. */
function affordanceMethods(segments: string[]): readonly string[] | null {
  const [, dir, name, sub, ...more] = segments;
  if (more.length > 0) return null;
  if (dir === "properties") return sub === undefined || sub === "observable" || sub === "sse" ? READ : null; // no name: readallproperties
  if (name === undefined) return null;
  if (dir === "events") return sub === undefined || sub === "sse" ? READ : null;
  if (dir === "actions") return sub === undefined ? ["POST"] : STATUS;
  return null;
}

function methodNotAllowed(res: ServerResponse, method: string, path: string, allow: readonly string[]): ServientError {
  res.setHeader("Allow", allow.join(", "));
  return servientError("E_METHOD_NOT_ALLOWED", `${method} is not allowed on ${path} (allowed: ${allow.join(", ")})`, { method, path, allow });
}

async function readBody(req: IncomingMessage): Promise<string> {
  const chunks: Buffer[] = [];
  let size = 0;
  for await (const chunk of req) {
    const b = chunk as Buffer;
    size += b.length;
    if (size > MAX_BODY) throw servientError("E_TOO_LARGE", `request body larger than ${MAX_BODY} bytes`, { limit: MAX_BODY });
    chunks.push(b);
  }
  return Buffer.concat(chunks).toString("utf8");
}

/**
 * An action's request body, before node-wot sees the request: JSON by media type (415), at most
 * `MAX_BODY` bytes (413, read no further), parsed (400) and valid against the action's input `schema`
 * (400; undefined: the action takes no input, an empty body). The stream is consumed: the handler takes
 * the value from the request context.
 */
export async function readActionBody(req: IncomingMessage, schema: object | undefined, action: string): Promise<unknown> {
  const type = req.headers["content-type"];
  const hasBody = Number(req.headers["content-length"] ?? 0) > 0 || req.headers["transfer-encoding"] !== undefined;
  if ((schema !== undefined || hasBody) && !isJsonMediaType(type)) {
    throw servientError("E_UNSUPPORTED_MEDIA_TYPE", `action bodies are JSON: send Content-Type: application/json (got ${type ?? "none"})`, { contentType: type ?? null });
  }
  // node-wot knows `application/json` only: any JSON media type accepted here is JSON to it
  if (type !== undefined) req.headers["content-type"] = "application/json";
  const body = parseBody(await readBody(req), schema !== undefined, action);
  validateInput(schema, body, action);
  return body;
}

/**
 * The SSE channels of each Thing (ids and history shared by its clients, `sse.ts`). A Thing's event
 * channels are made by the first request that names the Thing (`of` / `touch`; a consumer reads the TD
 * first), so every event after it is kept for a reconnecting client; a property's channel by its first stream.
 */
class SseChannels {
  private readonly byThing = new WeakMap<ServedThing, Map<string, SseChannel>>();

  /** the Thing's channels, its event channels made on the first call */
  touch(thing: ServedThing): Map<string, SseChannel> {
    let channels = this.byThing.get(thing);
    if (!channels) {
      this.byThing.set(thing, (channels = new Map()));
      for (const event of Object.keys((thing.td().events ?? {}) as object)) this.make(thing, channels, "events", event);
    }
    return channels;
  }

  /** the channel of a property or event, null when it is not observable */
  of(thing: ServedThing, kind: "properties" | "events", name: string): SseChannel | null {
    const channels = this.touch(thing);
    return channels.get(`${kind}/${name}`) ?? this.make(thing, channels, kind, name);
  }

  private make(thing: ServedThing, channels: Map<string, SseChannel>, kind: "properties" | "events", name: string): SseChannel | null {
    const source = thing.observe(kind, name);
    if (!source) return null;
    const channel = new SseChannel(name, source);
    channels.set(`${kind}/${name}`, channel);
    return channel;
  }
}

/** The request's decoded path (400 when its escapes are malformed). */
function decodedPath(url: URL): string {
  try {
    return decodeURIComponent(url.pathname);
  } catch {
    throw servientError("E_BAD_PATH", `malformed URL path ${url.pathname}`, { path: url.pathname });
  }
}

/** The guards every request passes first; true when one of them answered it (a preflight, a challenge). */
function guarded(env: MiddlewareEnv, req: IncomingMessage, res: ServerResponse, method: string, path: string): boolean {
  if (env.hop !== undefined && req.headers[HOP_HEADER] === env.hop) {
    throw servientError("E_LOOP", `${method} ${path} came from this servient itself (a relay, follow or register target, or a form of its TD, points back at it)`, { path });
  }
  env.guard.checkHost(req);
  if (method === "OPTIONS") {
    env.guard.preflight(req, res); // preflights carry no credentials
    return true;
  }
  env.guard.applyHeaders(res, env.guard.checkOrigin(req, RequestGuard.stateChanging(method)));
  if (env.auth && !isAuthorized(req, env.auth)) {
    challenge(res, env.auth);
    return true;
  }
  return false;
}

/** The servient's own routes (index, directory, viewer, the TD list); false when `path` is none of them. */
async function siteRoute(env: MiddlewareEnv, req: IncomingMessage, res: ServerResponse, url: URL, path: string, method: string): Promise<boolean> {
  const get = method === "GET" || method === "HEAD";
  if (path === "/robwot.json" && get) sendJson(res, 200, env.index());
  else if (isDirectoryPath(path)) {
    if (!get) throw methodNotAllowed(res, method, path, READ);
    directoryRoute(req, res, path, url.searchParams, env.directory);
  } else if (path === "/viewer" && get) {
    res.writeHead(301, { Location: `/viewer/${url.search}` });
    res.end();
  } else if (path.startsWith("/viewer/") && get) {
    const file = env.viewerDir ? confine(env.viewerDir, path.slice("/viewer/".length) || "index.html") : null;
    if (file) sendFile(req, res, file);
    else notFound(res, path);
  } else if (path === "/" && get) sendJson(res, 200, [...new Set(env.things.values())].map((t) => t.td()));
  else return false;
  return true;
}

/** An affordance route of `thing` (`segments`: slug, kind, name, sub-resource); node-wot's when `next` is called. */
async function affordanceRoute(thing: ServedThing, channels: SseChannels, req: IncomingMessage, res: ServerResponse, segments: string[], path: string, next: () => void): Promise<void> {
  const method = req.method ?? "GET";
  const allow = affordanceMethods(segments);
  if (!allow) return notFound(res, path);
  const kind = AFFORDANCE_KINDS[segments[1] ?? ""];
  const name = segments[2] ?? "";
  if (kind && segments.length >= 3) {
    const available = Object.keys((thing.td()[segments[1] as string] ?? {}) as object);
    if (!available.includes(name)) throw servientError("E_NOT_FOUND", `${thing.slug} has no ${kind} '${name}' (available: ${available.join(", ")})`, { path, available });
  }
  const statusId = kind === "action" ? segments[3] : undefined;
  const asynchronous = ASYNC_ACTIONS.filter((a) => thing.affordances.actions.has(a));
  if (statusId !== undefined && !asynchronous.includes(name)) {
    throw servientError("E_NOT_FOUND", `${path}: ${name} answers synchronously only (asynchronous: ${asynchronous.join(", ")})`, { path });
  }
  // a writable property (a conveyor's speed): PUT writes it, its value checked against its schema
  const writer = segments[1] === "properties" && segments[3] === undefined ? thing.affordances.writers?.get(name) : undefined;
  if (writer && method === "PUT") return writeProperty(res, writer, await readActionBody(req, writer.schema, name));
  if (!allow.includes(method)) throw methodNotAllowed(res, method, path, writer ? [...allow, "PUT"] : allow);
  if (statusId !== undefined) return actionStatusRoute(req, res, thing.statuses, name, statusId);
  if (segments[3] === "sse") {
    const stream = channels.of(thing, segments[1] as "properties" | "events", name);
    if (!stream) throw servientError("E_NOT_FOUND", `${path}: not observable`, { path });
    return streamSse(req, res, stream);
  }
  if (kind === "action") {
    const handler = thing.affordances.actions.get(name);
    if (!handler) throw servientError("E_NOT_FOUND", `${thing.slug} does not serve the action '${name}'`, { path });
    const input = await readActionBody(req, thing.actionInput(name) ?? undefined, name);
    // RFC 7240: a preference the action cannot honour is ignored (synchronous answer, no Preference-Applied)
    if (asynchronous.includes(name) && preferences(req).has(RESPOND_ASYNC)) {
      return respondAsync(res, thing.statuses, name, String(thing.td().base), (watch) => handler(input, watch));
    }
    return invokeAction(res, handler, input);
  }
  if (segments[1] === "properties" && segments[3] === undefined) return readProperty(res, thing.affordances, segments[2]);
  if (segments[3] === "observable") {
    // node-wot 0.9.2 unsubscribes a long-poll observer on 'finish' only: one that went away first
    // would have every later value piped into its dead response (listener leak)
    res.on("close", () => {
      if (!res.writableFinished) res.emit("finish");
    });
  }
  // what is left is node-wot's: the long-poll observe and event routes, fed by the same readers
  next();
}

export function createMiddleware(env: MiddlewareEnv) {
  const channels = new SseChannels();
  return async (req: IncomingMessage, res: ServerResponse, next: () => void): Promise<void> => {
    try {
      const url = new URL(req.url ?? "/", "http://localhost");
      const path = decodedPath(url);
      const method = req.method ?? "GET";
      if (guarded(env, req, res, method, path) || (await siteRoute(env, req, res, url, path, method))) return;
      const segments = path.split("/").filter((s) => s.length > 0);
      const thing = env.things.get(segments[0] ?? "");
      // nothing but our routes reaches node-wot: its second route per Thing (`/<url-encoded id>`) would
      // skip every check above and below
      if (!thing) return notFound(res, path);
      // the Thing's event channels start recording (for Last-Event-ID) no later than its first request
      channels.touch(thing);
      const rest = segments.slice(1).join("/");
      if (segments.length === 1 || isTwinFile(rest, thing.urdfName)) {
        if (method !== "GET" && method !== "HEAD") throw methodNotAllowed(res, method, path, READ);
        if (segments.length === 1) return sendJson(res, 200, thing.td(), "application/td+json");
        const file = confine(thing.dir, rest);
        return file ? sendFile(req, res, file) : notFound(res, path);
      }
      await affordanceRoute(thing, channels, req, res, segments, path, next);
    } catch (err) {
      // a request body left unread would be parsed as the next request on this connection: close it
      const unread = (Number(req.headers["content-length"] ?? 0) > 0 || req.headers["transfer-encoding"] !== undefined) && !req.readableEnded;
      if (!res.headersSent) sendProblem(res, toServientError(err), unread ? { Connection: "close" } : {});
      else res.end();
    }
  };
}
