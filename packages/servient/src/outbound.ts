/**
 * Every HTTP request the servient makes to another Thing (the physical robot's TD, its readings, relayed
 * commands and stops, a Thing Description Directory) goes through one `Outbound`:
 *
 * - **Deadlines**: the connection must be open within `connectMs`, the answer's first byte must come within
 *   `firstByteMs` (a read, a TD) or `invokeMs` (an action: a synchronous move answers when it ends), the
 *   whole answer within `totalMs` (`invokeMs` for actions). Past one the request is destroyed and fails
 *   naming the deadline.
 * - **Size cap**: an answer longer than `maxBytes` is cut there and the request fails naming the cap; it is
 *   never buffered past it (an endless body costs at most the cap).
 * - **No loops**: the target's address is resolved before connecting (and the connection pinned to it): a
 *   target that is this servient's own listening address is refused (`LoopError`), and every request says
 *   `RobWoT-Hop: <this servient's token>`, which this servient refuses with 508 (`hopHeader`), so an alias
 *   of itself that resolution did not recognise (a proxy, a name) cannot loop either.
 * - **Bounded in flight**: at most `perTarget` requests to one URL at a time; more fail at once.
 * - **No credentials in URLs**: `authorize(url)` moves a URL's userinfo into an `Authorization: Basic`
 *   header sent to that origin, and returns the URL without it, which is what the servient shows.
 * - Redirects are not followed (a 3xx is the answer): a Thing's forms name where to go.
 *
 * node-wot 0.9.2's HTTP client has no deadline and no size limit; `boundedHttpClientFactory` gives node-wot
 * a client whose transport is this one, so its consumer (form selection, content types, schemas) is kept.
 */
import { randomUUID } from "node:crypto";
import { lookup } from "node:dns/promises";
import http from "node:http";
import https from "node:https";
import { isIP } from "node:net";
import { networkInterfaces } from "node:os";
import { Readable } from "node:stream";
import { createRequire } from "node:module";

const require = createRequire(import.meta.url);
// node-wot's packages are CommonJS without named ESM exports
const { HttpClient } = require("@node-wot/binding-http") as typeof import("@node-wot/binding-http");

export interface OutboundLimits {
  connectMs: number;
  firstByteMs: number;
  totalMs: number;
  /** first byte and whole answer of an action (POST) */
  invokeMs: number;
  maxBytes: number;
  perTarget: number;
}

export const OUTBOUND_LIMITS: OutboundLimits = {
  connectMs: 3_000,
  firstByteMs: 5_000,
  totalMs: 10_000,
  invokeMs: 600_000,
  maxBytes: 1024 * 1024,
  perTarget: 8,
};

/** The header naming the servient that sent a request; the servient answers 508 to its own. */
export const HOP_HEADER = "robwot-hop";

/** A request to this servient itself. */
export class LoopError extends Error {
  override name = "LoopError";
}

export interface OutboundRequest {
  method?: string;
  headers?: Record<string, string>;
  body?: Buffer | string;
}

export interface OutboundAnswer {
  status: number;
  statusText: string;
  headers: http.IncomingHttpHeaders;
  body: Buffer;
}

const LOOPBACK = /^(127\.|::1$|::ffff:127\.)/;
const WILDCARD = new Set(["0.0.0.0", "::", ""]);
const bare = (h: string): string => h.replace(/^\[|\]$/g, "").toLowerCase();

/** `url` without its userinfo (the form every property, event, log line and document shows). */
export function redactUrl(url: string): string {
  try {
    const u = new URL(url);
    if (!u.username && !u.password) return url;
    u.username = "";
    u.password = "";
    return u.toString();
  } catch {
    return url.replace(/\/\/[^/@]*@/, "//");
  }
}

export class Outbound {
  /** sent as `RobWoT-Hop`; an incoming request carrying it came from this servient */
  readonly token = randomUUID();
  private readonly auth = new Map<string, string>();
  private readonly inFlight = new Map<string, number>();
  private self: { host: string; port: number } | null = null;
  private readonly agents = { http: new http.Agent({ keepAlive: true }), https: new https.Agent({ keepAlive: true }) };

  constructor(readonly limits: OutboundLimits = OUTBOUND_LIMITS) {}

  /** The address this servient listens on, once known: requests to it are loops. */
  listening(host: string, port: number): void {
    this.self = { host: bare(host), port };
  }

  /** `url` without userinfo; its credentials, if any, go to its origin as an Authorization header. */
  authorize(url: string): string {
    let u: URL;
    try {
      u = new URL(url);
    } catch {
      return url;
    }
    if (u.username || u.password) {
      const basic = Buffer.from(`${decodeURIComponent(u.username)}:${decodeURIComponent(u.password)}`).toString("base64");
      this.auth.set(u.origin, `Basic ${basic}`);
    }
    return redactUrl(url);
  }

  /** Refuses `url` when it resolves to this servient (`what` names the option, e.g. `--relay`). */
  async refuseSelf(url: string, what: string): Promise<void> {
    const u = new URL(url);
    const { address } = await this.resolve(u);
    if (this.isSelf(address, this.portOf(u))) throw new LoopError(`${what} ${redactUrl(url)} is this servient itself (${address}:${this.portOf(u)}): it would send its own requests to itself`);
  }

  /** Refuses a Thing's TD (fetched from `tdUrl`) any of whose forms points at this servient. */
  async refuseSelfForms(td: unknown, tdUrl: string, what: string): Promise<void> {
    const doc = (td ?? {}) as { base?: unknown; [kind: string]: unknown };
    const base = typeof doc.base === "string" ? doc.base : tdUrl;
    for (const kind of ["properties", "actions", "events"]) {
      for (const [name, affordance] of Object.entries((doc[kind] ?? {}) as Record<string, { forms?: { href?: unknown }[] }>)) {
        for (const form of affordance.forms ?? []) {
          if (typeof form.href !== "string") continue;
          let href: URL;
          try {
            href = new URL(form.href, base);
          } catch {
            continue;
          }
          if (href.protocol !== "http:" && href.protocol !== "https:") continue;
          await this.refuseSelf(href.toString(), `${what}: the form of ${kind}/${name} at`);
        }
      }
    }
  }

  private portOf(u: URL): number {
    return u.port ? Number(u.port) : u.protocol === "https:" ? 443 : 80;
  }

  private async resolve(u: URL): Promise<{ address: string; family: number }> {
    const host = bare(u.hostname);
    const family = isIP(host);
    return family ? { address: host, family } : lookup(host);
  }

  private isSelf(address: string, port: number): boolean {
    const self = this.self;
    if (!self || port !== self.port) return false;
    const a = bare(address).replace(/^::ffff:/, "");
    if (a === self.host) return true;
    // bound to one address: only that address is this servient; bound to every interface: each of them
    if (!WILDCARD.has(self.host)) return false;
    if (LOOPBACK.test(a)) return true;
    return Object.values(networkInterfaces()).some((list) => (list ?? []).some((i) => bare(i.address) === a));
  }

  /** One bounded request (see the module comment); resolves with the whole answer, whatever its status. */
  async request(url: string, init: OutboundRequest = {}): Promise<OutboundAnswer> {
    const u = new URL(url);
    if (u.protocol !== "http:" && u.protocol !== "https:") throw new Error(`${redactUrl(url)}: only http and https targets are requested`);
    const method = (init.method ?? "GET").toUpperCase();
    const key = `${method} ${redactUrl(url)}`;
    const n = this.inFlight.get(key) ?? 0;
    if (n >= this.limits.perTarget) throw new Error(`${key}: ${n} requests already in flight (at most ${this.limits.perTarget})`);
    this.inFlight.set(key, n + 1);
    try {
      const { address, family } = await this.resolve(u);
      if (this.isSelf(address, this.portOf(u))) throw new LoopError(`${redactUrl(url)} is this servient itself: the request would loop`);
      const headers: Record<string, string> = { ...init.headers, [HOP_HEADER]: this.token };
      if (u.username || u.password) this.authorize(url);
      const auth = this.auth.get(u.origin);
      if (auth && !Object.keys(headers).some((h) => h.toLowerCase() === "authorization")) headers.authorization = auth;
      u.username = "";
      u.password = "";
      return await this.send(u, method, headers, init.body, { address, family });
    } finally {
      const left = (this.inFlight.get(key) ?? 1) - 1;
      if (left > 0) this.inFlight.set(key, left);
      else this.inFlight.delete(key);
    }
  }

  private send(u: URL, method: string, headers: Record<string, string>, body: Buffer | string | undefined, to: { address: string; family: number }): Promise<OutboundAnswer> {
    const { connectMs, maxBytes } = this.limits;
    const action = method === "POST";
    const firstByteMs = action ? this.limits.invokeMs : this.limits.firstByteMs;
    const totalMs = action ? this.limits.invokeMs : this.limits.totalMs;
    const where = redactUrl(u.toString());
    return new Promise<OutboundAnswer>((resolve, reject) => {
      const timers: NodeJS.Timeout[] = [];
      const fail = (why: string): void => {
        req.destroy(new Error(`${method} ${where}: ${why}`));
      };
      const after = (ms: number, why: string): NodeJS.Timeout => {
        const t = setTimeout(() => fail(why), ms);
        timers.push(t);
        return t;
      };
      const done = (): void => timers.forEach(clearTimeout);
      const lib = u.protocol === "https:" ? https : http;
      const req = lib.request(u, {
        method,
        headers: body === undefined ? headers : { ...headers, "content-length": String(Buffer.byteLength(body)) },
        agent: u.protocol === "https:" ? this.agents.https : this.agents.http,
        // the address checked above, never a second resolution (a name that changes meanwhile)
        lookup: (_host, options, cb) => {
          if ((options as { all?: boolean }).all) (cb as unknown as (e: null, a: { address: string; family: number }[]) => void)(null, [to]);
          else cb(null, to.address, to.family);
        },
      });
      after(totalMs, `no complete answer within ${totalMs} ms`);
      const firstByte = after(firstByteMs, `no answer within ${firstByteMs} ms`);
      req.on("socket", (socket) => {
        if (!socket.connecting) return;
        const connect = after(connectMs, `not connected within ${connectMs} ms`);
        socket.once("connect", () => clearTimeout(connect));
      });
      req.on("error", (err) => {
        done();
        reject(err);
      });
      req.on("response", (res) => {
        clearTimeout(firstByte);
        const declared = Number(res.headers["content-length"] ?? 0);
        if (declared > maxBytes) return fail(`answer of ${declared} bytes is larger than ${maxBytes}`);
        const chunks: Buffer[] = [];
        let size = 0;
        res.on("data", (chunk: Buffer) => {
          size += chunk.length;
          if (size > maxBytes) return fail(`answer larger than ${maxBytes} bytes`);
          chunks.push(chunk);
        });
        res.on("error", (err) => {
          done();
          reject(err);
        });
        res.on("end", () => {
          done();
          resolve({ status: res.statusCode ?? 0, statusText: res.statusMessage ?? "", headers: res.headers, body: Buffer.concat(chunks) });
        });
      });
      req.end(body);
    });
  }

  /** Closes the kept-alive connections. */
  close(): void {
    this.agents.http.destroy();
    this.agents.https.destroy();
  }
}

/** The part of a node-fetch Request node-wot's HttpClient hands its transport. */
interface FetchRequest {
  url: string;
  method: string;
  headers: { raw(): Record<string, string[]> };
  body: unknown;
  buffer(): Promise<Buffer>;
}

/** node-wot's HTTP client with `Outbound` as its transport (only `_fetch`, the one place it sends). */
class BoundedHttpClient extends HttpClient {
  constructor(private readonly outbound: Outbound) {
    super(null);
  }

  /** Credentials are `Outbound`'s, per origin (a URL's userinfo): node-wot's own would need them per
   *  Thing id beforehand, and its basic scheme throws without them. */
  override setSecurity(): boolean {
    return true;
  }

  protected override async _fetch(request: FetchRequest): Promise<never> {
    const headers = Object.fromEntries(Object.entries(request.headers.raw()).map(([k, v]) => [k, v.join(", ")]));
    const body = request.body === null || request.body === undefined ? undefined : await request.buffer();
    const a = await this.outbound.request(request.url, { method: request.method, headers, ...(body && body.length > 0 ? { body } : {}) });
    const get = (name: string): string | null => {
      const v = a.headers[name.toLowerCase()];
      return v === undefined ? null : Array.isArray(v) ? v.join(", ") : v;
    };
    // node-wot reads these members of a node-fetch Response
    const response = {
      status: a.status,
      statusText: a.statusText,
      ok: a.status >= 200 && a.status < 300,
      url: request.url,
      headers: { get, raw: () => a.headers },
      body: Readable.from([a.body]),
    };
    return response as never;
  }
}

/** A node-wot client factory for `http` whose requests are `outbound`'s. */
export function boundedHttpClientFactory(outbound: Outbound): import("@node-wot/core").ProtocolClientFactory {
  const client = new BoundedHttpClient(outbound) as unknown as import("@node-wot/core").ProtocolClient;
  return { scheme: "http", getClient: () => client, init: () => true, destroy: () => true };
}
