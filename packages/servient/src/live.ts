/**
 * The `/live` WebSocket (Contract 4), plain `ws` on node-wot's own HTTP server (`upgrade` event).
 * Client -> server: `{"subscribe": "<slug>"}` (or `"*"` for every twin), `{"unsubscribe": "<slug>"}`;
 * `ws://host:port/live?thing=<slug>` subscribes at once. Server -> client:
 * `{thing, type: "joints", time, joints, position, orientation}` (>= 30 Hz of simulated time while moving),
 * `{thing, type: "status", ...motionStatus}`, `{thing, type: "collision", ...collision event}`,
 * `{thing, type: "scene", obstacles}` (the shared world's obstacles in scene.json's shape, after every
 * scene edit), `{type: "error", code, message, details}` for a bad message. A snapshot (joints, status,
 * scene) follows every subscription.
 */
import type { IncomingMessage, Server } from "node:http";
import type { Duplex } from "node:stream";
import { WebSocketServer, WebSocket } from "ws";
import { isAuthorized, type AuthConfig } from "./auth.js";
import { ServientError } from "./errors.js";
import type { RequestGuard } from "./request-guard.js";
import type { Twin } from "./twin.js";
import type { World } from "./world.js";

const MAX_BUFFERED = 1 << 20;

export interface LiveServer {
  close(): Promise<void>;
  clients(): number;
}

export function attachLive(server: Server, twins: Map<string, Twin>, world: World, auth: AuthConfig | undefined, guard: RequestGuard): LiveServer {
  const wss = new WebSocketServer({ noServer: true, maxPayload: 64 * 1024 });
  const subs = new Map<WebSocket, Set<string>>();

  const send = (ws: WebSocket, msg: unknown, droppable: boolean): void => {
    if (ws.readyState !== WebSocket.OPEN) return;
    if (droppable && ws.bufferedAmount > MAX_BUFFERED) return;
    ws.send(JSON.stringify(msg));
  };
  const broadcast = (slug: string, msg: unknown, droppable: boolean): void => {
    for (const [ws, set] of subs) if (set.has(slug)) send(ws, msg, droppable);
  };
  const sceneOf = (slug: string): object => ({ thing: slug, type: "scene", obstacles: world.sceneObstacles() });
  const onScene = (): void => {
    for (const slug of twins.keys()) broadcast(slug, sceneOf(slug), false);
  };
  world.on("scene", onScene);
  const detach: (() => void)[] = [() => world.off("scene", onScene)];
  for (const [slug, twin] of twins) {
    const onJoints = (m: unknown): void => broadcast(slug, m, true);
    const onStatus = (s: object): void => broadcast(slug, { thing: slug, type: "status", ...s }, false);
    const onCollision = (e: object): void => broadcast(slug, { thing: slug, type: "collision", ...e }, false);
    twin.on("joints", onJoints);
    twin.on("status", onStatus);
    twin.on("collision", onCollision);
    detach.push(() => {
      twin.off("joints", onJoints);
      twin.off("status", onStatus);
      twin.off("collision", onCollision);
    });
  }

  const subscribe = (ws: WebSocket, slug: string): void => {
    const set = subs.get(ws);
    if (!set) return;
    const targets = slug === "*" ? [...twins.keys()] : [slug];
    for (const s of targets) {
      const twin = twins.get(s);
      if (!twin) {
        send(ws, { type: "error", code: "E_UNKNOWN_THING", message: `no twin '${s}'`, details: { thing: s, available: [...twins.keys()] } }, false);
        continue;
      }
      set.add(s);
      send(ws, twin.liveJoints(), false);
      send(ws, { thing: s, type: "status", ...twin.status }, false);
      send(ws, sceneOf(s), false);
    }
  };

  const onUpgrade = (req: IncomingMessage, socket: Duplex, head: Buffer): void => {
    const url = new URL(req.url ?? "/", "http://localhost");
    if (url.pathname !== "/live") {
      socket.end("HTTP/1.1 404 Not Found\r\nConnection: close\r\n\r\n");
      return;
    }
    try {
      // a page of another origin must not even watch (it could time its commands on what it sees)
      guard.checkHost(req);
      guard.checkOrigin(req, true);
    } catch (err) {
      const e = err as ServientError;
      const body = JSON.stringify(e.toJSON());
      socket.end(`HTTP/1.1 ${e.status} ${e.code}\r\nContent-Type: application/json\r\nContent-Length: ${Buffer.byteLength(body)}\r\nConnection: close\r\n\r\n${body}`);
      return;
    }
    if (auth && !isAuthorized(req, auth)) {
      const scheme = auth.scheme === "basic" ? "Basic" : "Bearer";
      socket.end(`HTTP/1.1 401 Unauthorized\r\nWWW-Authenticate: ${scheme} realm="robwot"\r\nConnection: close\r\n\r\n`);
      return;
    }
    wss.handleUpgrade(req, socket, head, (ws) => {
      subs.set(ws, new Set());
      ws.on("close", () => subs.delete(ws));
      ws.on("error", () => subs.delete(ws));
      ws.on("message", (data) => {
        let msg: unknown;
        try {
          msg = JSON.parse(data.toString());
        } catch {
          send(ws, { type: "error", code: "E_BAD_JSON", message: "message is not JSON", details: {} }, false);
          return;
        }
        const m = (msg ?? {}) as { subscribe?: unknown; unsubscribe?: unknown };
        if (typeof m.subscribe === "string") subscribe(ws, m.subscribe);
        else if (typeof m.unsubscribe === "string") subs.get(ws)?.delete(m.unsubscribe);
        else {
          send(ws, { type: "error", code: "E_BAD_MESSAGE", message: 'expected {"subscribe": "<slug>"} or {"unsubscribe": "<slug>"}', details: {} }, false);
        }
      });
      const initial = url.searchParams.get("thing");
      if (initial) subscribe(ws, initial);
    });
  };
  server.on("upgrade", onUpgrade);

  return {
    clients: () => subs.size,
    close: async () => {
      server.off("upgrade", onUpgrade);
      detach.forEach((d) => d());
      for (const ws of subs.keys()) ws.terminate();
      await new Promise<void>((r) => wss.close(() => r()));
    },
  };
}
