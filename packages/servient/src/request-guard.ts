/**
 * Who may talk to the twin from a browser, checked on every HTTP request and every /live upgrade before
 * anything else runs:
 *
 * - `Host` must name the address served (DNS rebinding: a page on evil.example whose name resolves to
 *   127.0.0.1 sends `Host: evil.example`): the loopback names when bound to loopback, the `--host`
 *   address, the machine's interface addresses when bound to every interface, or an `--allowed-host`
 *   name; with the served port. Else 421 `E_MISDIRECTED`.
 * - `Origin`, when present, must be the twin's own origin (`http://<allowed host>:<port>`) or an
 *   `--cors-origin`; else a state-changing request (anything but GET/HEAD) or an upgrade answers 403
 *   `E_FORBIDDEN_ORIGIN`. Browsers send `Origin` on every cross-origin request and on every POST,
 *   including `no-cors` fetches, form posts and `sendBeacon`; clients outside a browser send none.
 * - CORS is granted to the `--cors-origin` origins only, never `*`: node-wot's own CORS headers are
 *   removed and ours written instead; preflights from other origins answer 403.
 * - Framing (clickjacking: a page overlays the viewer's Move/STOP buttons in an invisible frame): every
 *   response says `Content-Security-Policy: frame-ancestors 'self' <--cors-origin...>`.
 * - Action bodies must be JSON by media type (`application/json`, `application/<x>+json`), see
 *   `isJsonMediaType`; a "simple" browser request (`text/plain`, forms) can then never carry a command.
 */
import type { IncomingMessage, ServerResponse } from "node:http";
import { networkInterfaces } from "node:os";
import { servientError } from "./errors.js";

export interface GuardConfig {
  /** the bound address (`--host`) */
  host: string;
  /** the served port (known once listening) */
  port(): number;
  /** origins granted CORS and allowed to send commands (`--cors-origin`) */
  corsOrigins: readonly string[];
  /** extra names accepted in `Host` (`--allowed-host`) */
  allowedHosts: readonly string[];
  /** the command whose options the refusals name, and what it serves (default `serve`, `the twin`) */
  command?: { name: string; serves: string };
}

const LOOPBACK_NAMES = ["localhost", "127.0.0.1", "::1"];
const SAFE_METHODS = new Set(["GET", "HEAD"]);

const bare = (h: string): string => h.replace(/^\[|\]$/g, "").toLowerCase();
/** 127.0.0.0/8, ::1 and localhost (brackets and case ignored): reachable only from this machine. */
export const isLoopback = (h: string): boolean => LOOPBACK_NAMES.includes(bare(h)) || /^127\./.test(bare(h));
const isWildcard = (h: string): boolean => ["0.0.0.0", "::", ""].includes(bare(h));

/** Lower-cased host names (no brackets, no port) that may appear in `Host`. */
export function allowedHostNames(cfg: GuardConfig): Set<string> {
  const names = new Set<string>(cfg.allowedHosts.map(bare));
  names.add(bare(cfg.host));
  if (isLoopback(cfg.host) || isWildcard(cfg.host)) LOOPBACK_NAMES.forEach((n) => names.add(n));
  if (isWildcard(cfg.host)) {
    for (const list of Object.values(networkInterfaces())) for (const a of list ?? []) names.add(bare(a.address));
  }
  return names;
}

/** Splits a `Host` header into name and port (port null when absent). */
function parseHost(header: string): { name: string; port: number | null } | null {
  const m = /^(\[[^\]]+\]|[^:[\]]+)(?::(\d{1,5}))?$/.exec(header.trim());
  if (!m) return null;
  return { name: bare(m[1] as string), port: m[2] === undefined ? null : Number(m[2]) };
}

function normaliseOrigin(origin: string): string | null {
  try {
    const u = new URL(origin);
    return u.origin === "null" ? null : u.origin;
  } catch {
    return null;
  }
}

export class RequestGuard {
  private readonly names: Set<string>;
  private readonly cors: Set<string>;
  private readonly command: { name: string; serves: string };

  constructor(private readonly cfg: GuardConfig) {
    this.names = allowedHostNames(cfg);
    this.cors = new Set(cfg.corsOrigins.map((o) => normaliseOrigin(o) ?? o));
    this.command = cfg.command ?? { name: "serve", serves: "the twin" };
  }

  /** Throws 421 unless `Host` names this server (name and port). */
  checkHost(req: IncomingMessage): void {
    const header = req.headers.host;
    const parsed = header === undefined ? null : parseHost(header);
    const port = this.cfg.port();
    if (!parsed || !this.names.has(parsed.name) || (parsed.port ?? 80) !== port) {
      throw servientError("E_MISDIRECTED", `Host ${JSON.stringify(header ?? null)} is not served here (use one of ${[...this.names].join(", ")} with port ${port}, or start ${this.command.name} with --allowed-host NAME)`, {
        host: header ?? null,
        allowed: [...this.names],
        port,
      });
    }
  }

  /** True for the twin's own origins (an allowed host name with the served port, over http). */
  private isOwnOrigin(origin: string): boolean {
    const u = new URL(origin);
    const port = Number(u.port || (u.protocol === "https:" ? 443 : 80));
    return u.protocol === "http:" && this.names.has(bare(u.hostname)) && port === this.cfg.port();
  }

  /** The request's Origin when it is allowed (own or CORS), null without one; throws 403 otherwise for
   *  state-changing methods and upgrades. */
  checkOrigin(req: IncomingMessage, stateChanging: boolean): string | null {
    const raw = req.headers.origin;
    if (raw === undefined) return null;
    const origin = normaliseOrigin(raw);
    const allowed = origin !== null && (this.isOwnOrigin(origin) || this.cors.has(origin));
    if (allowed) return origin;
    if (stateChanging) {
      throw servientError("E_FORBIDDEN_ORIGIN", `requests from origin ${raw} may not drive ${this.command.serves} (start ${this.command.name} with --cors-origin ${raw} to allow a known dashboard)`, {
        origin: raw,
      });
    }
    return null;
  }

  /** Whether `method` changes state (everything but GET/HEAD; OPTIONS preflights are handled apart). */
  static stateChanging(method: string): boolean {
    return !SAFE_METHODS.has(method);
  }

  /** CORS headers for an allowed cross-origin request (node-wot's own `Access-Control-*` headers are
   *  dropped) and the framing policy: only the twin's own pages and `--cors-origin` pages may frame it. */
  applyHeaders(res: ServerResponse, origin: string | null): void {
    const setHeader = res.setHeader.bind(res);
    res.setHeader = ((name: string, value: number | string | readonly string[]) =>
      name.toLowerCase().startsWith("access-control-") ? res : setHeader(name, value)) as typeof res.setHeader;
    setHeader("Vary", "Origin");
    setHeader("Content-Security-Policy", ["frame-ancestors 'self'", ...this.cors].join(" "));
    if (origin !== null && this.cors.has(origin)) {
      setHeader("Access-Control-Allow-Origin", origin);
      setHeader("Access-Control-Allow-Credentials", "true");
      // an asynchronous invocation's ActionStatus URL (201) and the preference it applied
      setHeader("Access-Control-Expose-Headers", "Location, Preference-Applied");
    }
  }

  /** Answers an OPTIONS preflight: 204 with the allowed methods for a CORS origin, 403 for any other. */
  preflight(req: IncomingMessage, res: ServerResponse): void {
    const origin = normaliseOrigin(req.headers.origin ?? "");
    if (origin === null || !this.cors.has(origin)) {
      throw servientError("E_FORBIDDEN_ORIGIN", `no CORS grant for origin ${req.headers.origin ?? "(none)"}`, {
        origin: req.headers.origin ?? null,
      });
    }
    res.writeHead(204, {
      "Access-Control-Allow-Origin": origin,
      "Access-Control-Allow-Credentials": "true",
      "Access-Control-Allow-Methods": "GET, HEAD, POST, PUT, DELETE, OPTIONS",
      "Access-Control-Allow-Headers": "content-type, authorization, prefer",
      "Access-Control-Max-Age": "600",
      Vary: "Origin",
    });
    res.end();
  }
}

/** `application/json` or `application/<anything>+json`, parameters (charset) allowed. */
export function isJsonMediaType(contentType: string | undefined): boolean {
  if (contentType === undefined) return false;
  const type = (contentType.split(";")[0] ?? "").trim().toLowerCase();
  return /^application\/([a-z0-9.!#$&^_-]+\+)?json$/.test(type);
}

/** Depth of the deepest array/object nesting in a JSON text (strings skipped), without parsing it. */
export function jsonDepth(text: string): number {
  let depth = 0;
  let max = 0;
  let inString = false;
  for (let i = 0; i < text.length; i++) {
    const c = text.charCodeAt(i);
    if (inString) {
      if (c === 0x5c) i++; // backslash: skip the escaped character
      else if (c === 0x22) inString = false;
    } else if (c === 0x22) inString = true;
    else if (c === 0x7b || c === 0x5b) max = Math.max(max, ++depth);
    else if (c === 0x7d || c === 0x5d) depth--;
  }
  return max;
}
