/**
 * Authentication for every affordance, file and the /live socket. node-wot 0.9.2's producer-side
 * bearer check answers 401 to every request (a case mismatch in its checkCredentials), so both schemes
 * are enforced here, before node-wot sees the request; node-wot itself runs with nosec and the served TD
 * says what is required.
 */
import { timingSafeEqual } from "node:crypto";
import type { IncomingMessage, ServerResponse } from "node:http";
import { sendProblem, servientError } from "./errors.js";

export type AuthConfig = { scheme: "basic"; user: string; password: string } | { scheme: "bearer"; token: string };

function safeEqual(a: string, b: string): boolean {
  const x = Buffer.from(a);
  const y = Buffer.from(b);
  return x.length === y.length && timingSafeEqual(x, y);
}

/**
 * True when the request carries the configured credentials: `Authorization: Basic|Bearer ...`; for
 * bearer also `?access_token=` (browsers cannot set headers on a WebSocket).
 */
export function isAuthorized(req: IncomingMessage, auth: AuthConfig | undefined): boolean {
  if (!auth) return true;
  const header = req.headers.authorization ?? "";
  const space = header.indexOf(" ");
  const kind = space > 0 ? header.slice(0, space).toLowerCase() : "";
  const value = space > 0 ? header.slice(space + 1).trim() : "";
  if (auth.scheme === "basic") {
    if (kind !== "basic") return false;
    const decoded = Buffer.from(value, "base64").toString("utf8");
    const colon = decoded.indexOf(":");
    if (colon < 0) return false;
    return safeEqual(decoded.slice(0, colon), auth.user) && safeEqual(decoded.slice(colon + 1), auth.password);
  }
  if (kind === "bearer") return safeEqual(value, auth.token);
  const q = new URL(req.url ?? "/", "http://x").searchParams.get("access_token");
  return q !== null && safeEqual(q, auth.token);
}

export function challenge(res: ServerResponse, auth: AuthConfig): void {
  const scheme = auth.scheme === "basic" ? "Basic" : "Bearer";
  const err = servientError("E_UNAUTHORIZED", `${scheme} credentials required`, { scheme: auth.scheme });
  sendProblem(res, err, { "WWW-Authenticate": `${scheme} realm="robwot"` });
}
