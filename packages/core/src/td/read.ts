/**
 * Reading what a consumer needs out of a RobWoT Thing Description (ARCHITECTURE.md Contract 3): joint
 * limits from `getJointPosition`'s schema, Cartesian bounds from the `moveToCartesianPosition` input, the
 * linked files, and the live WebSocket endpoint (Contract 4). Shared by the consumers and the viewer.
 */
import { RobwotError } from "../errors.js";
import { LIVE_REL } from "./build.js";

export interface SchemaLike {
  type?: string;
  minimum?: number;
  maximum?: number;
  unit?: string;
  properties?: Record<string, SchemaLike>;
  [key: string]: unknown;
}
export interface FormLike {
  href: string;
  subprotocol?: string;
  op?: string | string[];
  [key: string]: unknown;
}
export interface AffordanceLike extends SchemaLike {
  forms?: FormLike[];
  input?: SchemaLike;
  output?: SchemaLike;
}
export interface LinkLike {
  rel?: string;
  href: string;
  type?: string;
}
export interface ThingDescriptionLike {
  id?: string;
  title?: string;
  base?: string;
  properties?: Record<string, AffordanceLike>;
  actions?: Record<string, AffordanceLike>;
  events?: Record<string, AffordanceLike>;
  links?: LinkLike[];
  forms?: FormLike[];
  [key: string]: unknown;
}

export class TdError extends RobwotError {
  override name = "TdError";
  constructor(message: string, details: Record<string, unknown> = {}) {
    super("E_TD", message, details);
  }
}

export interface JointLimit {
  name: string;
  lower: number;
  upper: number;
  unit: string;
}

/** Joint limits in TD order, from `properties.getJointPosition.properties.<joint>.minimum/maximum`. */
export function jointLimits(td: ThingDescriptionLike): JointLimit[] {
  const joints = td.properties?.["getJointPosition"]?.properties;
  if (joints === undefined) throw new TdError(`TD "${td.title ?? "?"}" has no getJointPosition object schema`);
  return Object.entries(joints).map(([name, s]) => {
    if (typeof s.minimum !== "number" || typeof s.maximum !== "number") {
      throw new TdError(`TD joint "${name}" lacks numeric minimum/maximum (got ${String(s.minimum)}, ${String(s.maximum)})`);
    }
    return { name, lower: s.minimum, upper: s.maximum, unit: s.unit ?? "rad" };
  });
}

export interface Bounds3 {
  min: [number, number, number];
  max: [number, number, number];
}

/**
 * Cartesian bounds of the collision-free workspace: x/y/z minimum/maximum of the
 * `moveToCartesianPosition` input schema (what the twin accepts), else of `getCartesianPosition`.
 */
export function cartesianBounds(td: ThingDescriptionLike): Bounds3 {
  const sources = [td.actions?.["moveToCartesianPosition"]?.input?.properties];
  const axis = (k: "x" | "y" | "z"): [number, number] => {
    for (const props of sources) {
      const s = props?.[k];
      if (typeof s?.minimum === "number" && typeof s.maximum === "number") return [s.minimum, s.maximum];
    }
    throw new TdError(`TD declares no numeric minimum/maximum for ${k} (moveToCartesianPosition input)`);
  };
  const [x, y, z] = [axis("x"), axis("y"), axis("z")];
  return { min: [x[0], y[0], z[0]], max: [x[1], y[1], z[1]] };
}

/** The speed fractions a move accepts: `minimum`/`maximum` of `moveToJointPosition`'s `speed` input. */
export function speedRange(td: ThingDescriptionLike): { minimum: number; maximum: number } {
  const s = td.actions?.["moveToJointPosition"]?.input?.properties?.["speed"];
  if (typeof s?.minimum !== "number" || typeof s.maximum !== "number") {
    throw new TdError("TD declares no numeric minimum/maximum for speed (moveToJointPosition input)");
  }
  return { minimum: s.minimum, maximum: s.maximum };
}

/** Absolute URL of the link with `rel`, resolved against the TD's `base` (else the TD URL). */
export function linkUrl(td: ThingDescriptionLike, rel: string, tdUrl: string): string {
  const link = td.links?.find((l) => l.rel === rel);
  if (link === undefined) {
    const rels = (td.links ?? []).map((l) => l.rel ?? "?").join(", ");
    throw new TdError(`TD has no link with rel "${rel}" (links: ${rels || "none"})`);
  }
  const base = td.base ?? tdUrl;
  return new URL(link.href, base.endsWith("/") ? base : `${base}/`).toString();
}

/** The Thing's slug: the last path segment of its TD URL. */
export function slugOf(tdUrl: string): string {
  const parts = new URL(tdUrl).pathname.split("/").filter((p) => p !== "");
  const last = parts[parts.length - 1];
  if (last === undefined) throw new TdError(`TD URL ${tdUrl} has no Thing path segment`);
  return decodeURIComponent(last);
}

/** The servient's live WebSocket stream: the TD's link with rel `robwot:live`. */
export function liveUrl(td: ThingDescriptionLike): string | undefined {
  return td.links?.find((l) => l.rel === LIVE_REL && typeof l.href === "string")?.href;
}
