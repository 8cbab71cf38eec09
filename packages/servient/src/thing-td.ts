/**
 * The TD of a twin, two ways:
 * - `produceInit`: what node-wot's `WoT.produce` gets: the generated td.json without forms and base
 *   (node-wot adds its own forms for the real address), with nosec (auth is enforced by the middleware).
 * - `servedTd`: what `/<slug>` answers: td.json with `base` = `<url>/<slug>/`, the `robwot:live` link
 *   pointing at this servient's `/live`, the security required (`securityFor`), and the Cartesian
 *   bounds in the real frame when a calibration is active.
 */
import { type Bounds, type FrameMap, LIVE_REL, securityFor, TD_CONTEXT_V10, type ThingDescription, withAbsoluteForms, WOT_PROFILES } from "@robwot/core";
import type { AuthConfig } from "./auth.js";
import type { TdDocument } from "./twin-folder.js";

type Json = Record<string, unknown>;

const clone = <T>(v: T): T => structuredClone(v);

function eachAffordance(td: TdDocument, fn: (a: Json, kind: "properties" | "actions" | "events", name: string) => void): void {
  for (const kind of ["properties", "actions", "events"] as const) {
    for (const [name, a] of Object.entries((td[kind] ?? {}) as Record<string, Json>)) fn(a, kind, name);
  }
}

export function produceInit(td: TdDocument): WoT.ExposedThingInit {
  const init = clone(td);
  delete init.forms;
  delete init.base;
  eachAffordance(init, (a, kind) => {
    delete a.forms;
    // the ActionStatus template of the asynchronous moves is served by the middleware, not node-wot (its
    // HttpServer would put the variable into the invokeaction route)
    if (kind === "actions") delete a.uriVariables;
  });
  // node-wot 0.9.2 validates the init against the TD 1.0 schema: its context URL only
  const ctx = Array.isArray(init["@context"]) ? (init["@context"] as unknown[]) : [];
  init["@context"] = [TD_CONTEXT_V10, ...ctx.filter((c) => typeof c === "object")];
  init.securityDefinitions = { nosec_sc: { scheme: "nosec" } };
  init.security = "nosec_sc";
  return init as unknown as WoT.ExposedThingInit;
}

function setBounds(schema: Json | undefined, b: Bounds): void {
  const props = schema?.properties as Record<string, Json> | undefined;
  if (!props) return;
  (["x", "y", "z"] as const).forEach((axis, i) => {
    const s = props[axis];
    if (s && typeof s.minimum === "number") s.minimum = b.min[i];
    if (s && typeof s.maximum === "number") s.maximum = b.max[i];
  });
}

export interface ServeTdOptions {
  url: string;
  slug: string;
  liveUrl: string;
  auth?: AuthConfig | undefined;
  frames: FrameMap;
  bounds: Bounds | null;
}

export function servedTd(td: TdDocument, o: ServeTdOptions): TdDocument {
  // forms absolute and moved to the served address (td.json of older versions had relative ones)
  const out = withAbsoluteForms(clone(td), `${o.url}/${o.slug}/`);
  // the servient answers as the WoT Profiles say, also for a td.json written before it said so
  const doc = out as Json;
  doc.profile ??= [...WOT_PROFILES];
  eachAffordance(out, (a, kind) => {
    if (kind === "actions") a.synchronous ??= true;
  });
  for (const l of (out.links ?? []) as Json[]) if (l.rel === LIVE_REL) l.href = o.liveUrl;
  if (o.bounds && o.frames.transform) {
    const b = o.frames.boundsToReal(o.bounds);
    setBounds(out.actions?.moveToCartesianPosition?.input as Json | undefined, b);
    setBounds(out.actions?.validateCartesianPosition?.input as Json | undefined, b);
  }
  const secured = securityFor(out as unknown as ThingDescription, o.auth ? { scheme: o.auth.scheme } : null);
  return secured as unknown as TdDocument;
}
