/**
 * The HTTP front of `robwot emulate` (node-wot HttpServer `middleware`): the twin's protections and the
 * twin's own affordance routes, so no request reaches node-wot's router (node-wot produced the Thing).
 *
 * - `Host` names the address served (421), a foreign `Origin` may not command (403), CORS only for
 *   `--cors-origin` and never `*` (`RequestGuard`); `--auth` on everything, the TD included (`auth.ts`).
 * - Only the emulated Thing's routes are served: its TD, property reads and action invocations under
 *   `/<slug>` (node-wot's second route per Thing, `/<url-encoded id>`, answers 404 like anything else;
 *   a method a route does not serve 405).
 * - A property read answers its reader's value as JSON, or the bytes of another media type its form names
 *   (`pointCloud`, a PLY); `readallproperties` holds the JSON ones only.
 * - An action body is JSON by media type (415), at most `MAX_BODY` bytes (413: read no further), parsed and
 *   valid against the action's input schema (400) (`readActionBody`); a handler's ServientError answers with
 *   its own status. Every error answer is problem details (`errors.ts`).
 */
import type { IncomingMessage, ServerResponse } from "node:http";
import { securityFor, type ThingDescription } from "@robwot/core";
import { challenge, isAuthorized, type AuthConfig } from "./auth.js";
import { invokeAction, readProperty, type Affordances } from "./affordance-routes.js";
import { toServientError, sendProblem, ServientError, servientError } from "./errors.js";
import { readActionBody } from "./http-middleware.js";
import { RequestGuard } from "./request-guard.js";
import { sendJson } from "./static-files.js";

type Json = Record<string, unknown>;

/** The exposed Thing as the middleware serves it. */
export interface EmulatedThing {
  /** node-wot's path segment of the Thing (its title, slugified) */
  slug: string;
  /** the TD as served: forms of the `/<slug>` route in JSON only, the security `--auth` requires */
  td: Json;
  /** its property readers and action handlers */
  affordances: Affordances;
}

export interface EmulatorHttpEnv {
  guard: RequestGuard;
  auth: AuthConfig | undefined;
  /** null until node-wot has exposed the Thing (the port listens a little earlier) */
  thing(): EmulatedThing | null;
}

const READ = ["GET", "HEAD"] as const;

/**
 * The TD node-wot made for the Thing, as the emulator serves it: only the forms it lets through (the
 * `/<slug>` route, JSON: node-wot also offers CBOR and its `/<url-encoded id>` route), those of the
 * properties in `media` in the media type their readers answer in, and the security `auth` requires
 * (node-wot itself runs with nosec: the middleware checks the credentials).
 */
export function emulatorTd(td: Json, slug: string, auth: AuthConfig | undefined, media: Record<string, string> = {}): Json {
  const out = structuredClone(td);
  const keep = (forms: unknown): Json[] =>
    ((forms ?? []) as Json[]).filter((f) => {
      const path = new URL(String(f.href), "http://x").pathname;
      return (path === `/${slug}` || path.startsWith(`/${slug}/`)) && (f.contentType ?? "application/json") === "application/json";
    });
  out.forms = keep(out.forms);
  for (const kind of ["properties", "actions", "events"] as const) {
    for (const a of Object.values((out[kind] ?? {}) as Record<string, Json>)) a.forms = keep(a.forms);
  }
  for (const [name, contentType] of Object.entries(media)) {
    const p = ((out.properties ?? {}) as Record<string, Json>)[name];
    if (p) p.forms = (p.forms as Json[]).map((f) => ({ ...f, contentType }));
  }
  return securityFor(out as unknown as ThingDescription, auth ? { scheme: auth.scheme } : null) as unknown as Json;
}

function methodNotAllowed(res: ServerResponse, method: string, path: string, allow: readonly string[]): ServientError {
  res.setHeader("Allow", allow.join(", "));
  return servientError("E_METHOD_NOT_ALLOWED", `${method} is not allowed on ${path} (allowed: ${allow.join(", ")})`, { method, path, allow });
}

/** The readers `readallproperties` answers with: those of the properties whose forms are JSON (one read as
 *  bytes of another media type is read on its own). */
function jsonReaders(thing: EmulatedThing): Affordances {
  const declared = (thing.td.properties ?? {}) as Record<string, Json>;
  const json = (name: string): boolean => ((declared[name]?.forms ?? []) as Json[]).every((f) => (f.contentType ?? "application/json") === "application/json");
  return { ...thing.affordances, properties: new Map([...thing.affordances.properties].filter(([name]) => json(name))) };
}

/** The methods of a route of the Thing, null when there is no such route (404). */
function routeMethods(td: Json, segments: string[]): readonly string[] | null {
  const [, dir, name, ...more] = segments;
  if (more.length > 0) return null;
  if (dir === undefined) return READ; // the TD
  if (dir === "properties") return name === undefined || name in ((td.properties ?? {}) as Json) ? READ : null;
  if (dir === "actions") return name !== undefined && name in ((td.actions ?? {}) as Json) ? ["POST"] : null;
  return null;
}

export function emulatorMiddleware(env: EmulatorHttpEnv) {
  return async (req: IncomingMessage, res: ServerResponse): Promise<void> => {
    try {
      const raw = new URL(req.url ?? "/", "http://localhost").pathname;
      let path: string;
      try {
        path = decodeURIComponent(raw);
      } catch {
        throw servientError("E_BAD_PATH", `malformed URL path ${raw}`, { path: raw });
      }
      const method = req.method ?? "GET";
      env.guard.checkHost(req);
      if (method === "OPTIONS") return env.guard.preflight(req, res); // preflights carry no credentials
      env.guard.applyHeaders(res, env.guard.checkOrigin(req, RequestGuard.stateChanging(method)));
      if (env.auth && !isAuthorized(req, env.auth)) return challenge(res, env.auth);

      const thing = env.thing();
      if (!thing) throw servientError("E_STARTING", "the emulated robot is starting; retry shortly");
      const segments = path.split("/").filter((s) => s.length > 0);
      const allow = segments[0] === thing.slug ? routeMethods(thing.td, segments) : null;
      if (!allow) throw servientError("E_NOT_FOUND", `${path} not found (the emulated robot's TD is /${thing.slug})`, { path });
      if (!allow.includes(method)) throw methodNotAllowed(res, method, path, allow);
      if (segments.length === 1) return sendJson(res, 200, thing.td, "application/td+json");
      const name = segments[2];
      if (segments[1] === "properties") return await readProperty(res, name === undefined ? jsonReaders(thing) : thing.affordances, name);
      const handler = thing.affordances.actions.get(name ?? "");
      if (!handler || name === undefined) throw servientError("E_NOT_FOUND", `${path} not found`, { path });
      const action = ((thing.td.actions ?? {}) as Record<string, Json>)[name];
      return await invokeAction(res, handler, await readActionBody(req, action?.input as object | undefined, name));
    } catch (err) {
      if (!res.headersSent) sendProblem(res, toServientError(err));
      else res.end();
    }
  };
}
