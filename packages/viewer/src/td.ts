/**
 * The twin's Thing Description as the viewer needs it: affordance URLs (HTTP forms), joint limits,
 * and the linked model / workspace files (Contract 3).
 */
import { jointLimits, type JointLimit, linkUrl, liveUrl, REACHABILITY_REL, RobwotError, speedRange, type TdCoupling, tdCouplings, TdError, type ThingDescriptionLike, TWIN_FILES } from "@robwot/core/browser";
import { ViewerError } from "./errors.js";
import { fetchJson, isRecord } from "./http.js";

export interface TwinTd {
  title: string;
  /** URL the TD was fetched from. */
  url: string;
  /** Base against which link hrefs resolve (`<base-url><slug>/`). */
  base: string;
  raw: Record<string, unknown>;
  joints: JointLimit[];
  /** The speed fractions a move accepts (the move actions' `speed` input). */
  speed: { minimum: number; maximum: number };
  links: { model: string; pointCloud: string | null; workspace: string | null; reachability: string | null; summary: string | null; scene: string | null };
  /** End-effector link (`robwot:eeLink`), if the TD names one. */
  eeLink: string | null;
  /** The joints that follow others (`robwot:couplings`): drawn where the linkage puts them. */
  couplings: TdCoupling[];
  /** Live WebSocket endpoint from the TD's link with rel `robwot:live` (Contract 4), if any. */
  live: string | null;
}

export async function loadTd(slug: string): Promise<TwinTd> {
  const url = new URL(`/${encodeURIComponent(slug)}`, location.href).href;
  const raw = await fetchJson(url);
  if (!isRecord(raw)) throw new ViewerError("E_TD", `TD at ${url} is not a JSON object`);
  const base = typeof raw["base"] === "string" ? ensureSlash(raw["base"]) : `${url}/`;
  // core's TD reading; a link the TD does not have is null here (only the model is required)
  const link = (rel: string): string | null => {
    try {
      return sameOrigin(linkUrl({ ...(raw as ThingDescriptionLike), base }, rel, url));
    } catch (err) {
      if (err instanceof TdError) return null;
      throw err;
    }
  };
  const model = link("model");
  if (model === null) throw new ViewerError("E_TD", `TD at ${url} has no link with rel "model" (the URDF)`);
  return {
    title: typeof raw["title"] === "string" ? raw["title"] : slug,
    url,
    base,
    raw,
    joints: readJointLimits(raw),
    speed: fromCore(() => speedRange(raw as ThingDescriptionLike)),
    links: {
      model,
      pointCloud: link("workspace-pointcloud"),
      workspace: link("workspace"),
      reachability: link(REACHABILITY_REL),
      summary: link("workspace-summary"),
      scene: link("scene") ?? new URL(TWIN_FILES.scene, base).href,
    },
    live: liveLink(raw),
    eeLink: typeof raw["robwot:eeLink"] === "string" ? raw["robwot:eeLink"] : null,
    couplings: tdCouplings(raw),
  };
}


/** The `/live` link of the TD, on the host name this page reached (same machine, advertised port). */
function liveLink(td: Record<string, unknown>): string | null {
  const href = liveUrl(td as ThingDescriptionLike);
  if (href === undefined || !/^wss?:/.test(href)) return null;
  const u = new URL(href);
  u.hostname = location.hostname;
  return u.href;
}

/** Joint limits (core's TD reading). */
function readJointLimits(td: Record<string, unknown>): JointLimit[] {
  return fromCore(() => jointLimits(td as ThingDescriptionLike));
}

/** A reading of core's TD reader; what it refuses is the viewer's E_TD. */
function fromCore<T>(read: () => T): T {
  try {
    return read();
  } catch (err) {
    if (err instanceof RobwotError) throw new ViewerError("E_TD", err.message, err.details);
    throw err;
  }
}

function affordance(td: Record<string, unknown>, kind: string, name: string): Record<string, unknown> | null {
  const group = td[kind];
  if (!isRecord(group)) return null;
  const a = group[name];
  return isRecord(a) ? a : null;
}

/**
 * URL of an HTTP form of an affordance for the given op (no subprotocol such as longpoll). Forms on our
 * own origin are preferred: node-wot may list one form per network interface. The page is served by the
 * servient's own HTTP server (Contract 4), so another host name for it is mapped onto our origin.
 */
export function formUrl(td: TwinTd, kind: "properties" | "actions", name: string, op: string): string {
  const a = affordance(td.raw, kind, name);
  if (!a) throw new ViewerError("E_TD", `TD has no ${kind === "properties" ? "property" : "action"} "${name}"`);
  const forms = Array.isArray(a["forms"]) ? a["forms"].filter(isRecord) : [];
  const candidates = forms
    .filter((f) => typeof f["href"] === "string" && f["subprotocol"] === undefined)
    .filter((f) => {
      const ops = f["op"];
      return ops === undefined || ops === op || (Array.isArray(ops) && ops.includes(op));
    })
    .map((f) => new URL(String(f["href"]), td.base))
    .filter((u) => u.protocol === "http:" || u.protocol === "https:");
  const own = candidates.find((u) => u.origin === location.origin);
  const chosen = own ?? candidates[0];
  if (!chosen) throw new ViewerError("E_TD", `no HTTP form with op ${op} for ${name}`);
  return sameOrigin(chosen.href);
}

export async function readProperty(td: TwinTd, name: string): Promise<unknown> {
  return fetchJson(formUrl(td, "properties", name, "readproperty"));
}

export async function invokeAction(td: TwinTd, name: string, input?: unknown): Promise<unknown> {
  const init: RequestInit = { method: "POST" };
  if (input !== undefined) {
    init.headers = { "content-type": "application/json" };
    init.body = JSON.stringify(input);
  }
  return fetchJson(formUrl(td, "actions", name, "invokeaction"), init);
}

function ensureSlash(u: string): string {
  return u.endsWith("/") ? u : `${u}/`;
}

/**
 * Links and forms may name another interface address of this same servient (node-wot 0.9.2 writes forms
 * for every local interface). The servient that served this page serves them too: keep the path.
 */
function sameOrigin(href: string): string {
  const u = new URL(href);
  return u.origin === location.origin ? href : new URL(u.pathname + u.search, location.origin).href;
}
