/**
 * The `/live` WebSocket (Contract 4), plain `ws` on node-wot's own HTTP server (`upgrade` event).
 * Client -> server: `{"subscribe": "<slug>"}` (or `"*"` for every twin), `{"unsubscribe": "<slug>"}`;
 * `ws://host:port/live?thing=<slug>` subscribes at once. Server -> client:
 * `{thing, type: "joints", time, joints, position, orientation}` (>= 30 Hz of simulated time while moving),
 * `{thing, type: "status", ...motionStatus}`, `{thing, type: "collision", ...collision event}`,
 * `{thing, type: "scene", obstacles}` (the shared world's obstacles in scene.json's shape, after every
 * scene edit; edits in a burst share one frame, at most 30 per second, the last one always reflecting the
 * latest edit), `{type: "error", code, message, details}` for a bad message. A snapshot (joints, status,
 * scene) follows every subscription.
 *
 * Resuming: every message of the stream (not an error reply) carries `seq`, one sequence per servient,
 * increasing across connections and restarts (`event-history.ts`). Events (collision, divergence,
 * collisionImminent) are kept, the last `EVENT_HISTORY` per twin: `?thing=<slug>&resume=<seq>` or
 * `{"subscribe": "<slug>", "resume": <seq>}` first replays the kept events after `seq` (in order, with
 * their own `seq`), then the snapshot; when events after `seq` are no longer known (the history
 * overflowed, or `seq` is of an earlier run) a `{thing, type: "gap", resume, firstKept, reason:
 * "overflow" | "restart"}` message (no `seq`) comes first. States need no replay: the snapshot is the latest.
 *
 * Each client has a `PushQueue` (push-queue.ts): its joints, status and scene messages coalesce to the
 * latest of each per thing, collision events and error replies are kept up to a bound, and a client that
 * stays behind is closed with code 1008 and the reason. A broadcast is serialised once, into one buffer
 * that every client's socket shares.
 */
import type { IncomingMessage, Server } from "node:http";
import type { Duplex } from "node:stream";
import { WebSocketServer, WebSocket } from "ws";
import { PROBLEM_JSON } from "@robwot/core";
import { isAuthorized, type AuthConfig } from "./auth.js";
import { EventHistory, resumePoint, Sequence } from "./event-history.js";
import { ServientError } from "./errors.js";
import { PushQueue, type PushTransport } from "./push-queue.js";
import type { RequestGuard } from "./request-guard.js";
import type { Twin } from "./twin.js";
import type { World } from "./world.js";

/** WebSocket close code for a client closed for being too slow: policy violation (RFC 6455 7.4.1) */
const CLOSE_TOO_SLOW = 1008;
/** scene frames are sent at most this often (the latest scene; a viewer draws at display rate) */
const SCENE_INTERVAL_MS = 1000 / 30;

function wsTransport(ws: WebSocket): PushTransport<Buffer> {
  return {
    buffered: () => ws.bufferedAmount,
    write: (data, done) => {
      if (ws.readyState === WebSocket.OPEN) ws.send(data, { binary: false }, done);
    },
    // a close reason is at most 123 bytes
    close: (reason) => ws.close(CLOSE_TOO_SLOW, reason.slice(0, 120)),
    destroy: () => ws.terminate(),
  };
}

export interface LiveServer {
  close(): Promise<void>;
  clients(): number;
}

export function attachLive(server: Server, twins: Map<string, Twin>, world: World, auth: AuthConfig | undefined, guard: RequestGuard): LiveServer {
  const wss = new WebSocketServer({ noServer: true, maxPayload: 64 * 1024 });
  const clients = new Map<WebSocket, { things: Set<string>; queue: PushQueue<Buffer> }>();

  // one sequence for every message of the stream; the events of each twin kept for resuming clients
  const seq = new Sequence();
  const kept = new Map([...twins.keys()].map((slug) => [slug, new EventHistory<Buffer>(seq)]));
  const stamp = (msg: object, n: number): Buffer => Buffer.from(JSON.stringify({ ...msg, seq: n }));

  /** key: what the message coalesces with (`<kind>:<slug>`), null for an event or a reply (kept) */
  const send = (ws: WebSocket, key: string | null, msg: object, numbered = true): void => {
    clients.get(ws)?.queue.push(key, numbered ? stamp(msg, seq.take()) : Buffer.from(JSON.stringify(msg)));
  };
  const broadcast = (slug: string, kind: "joints" | "status" | "scene" | "collision" | "divergence" | "collisionImminent" | "physical", msg: object): void => {
    let data: Buffer | null = null;
    // events are kept (up to a bound, also here for resuming clients); of a state, the latest replaces a queued one
    const event = kind === "collision" || kind === "divergence" || kind === "collisionImminent";
    if (event) data = kept.get(slug)!.record((n) => stamp(msg, n));
    const key = event ? null : `${kind}:${slug}`;
    for (const { things, queue } of clients.values()) {
      if (!things.has(slug)) continue;
      data ??= stamp(msg, seq.take());
      queue.push(key, data);
    }
  };
  const sceneOf = (slug: string): object => ({ thing: slug, type: "scene", obstacles: world.sceneObstacles() });
  // at most one scene frame per SCENE_INTERVAL_MS, the latest scene: a burst of edits costs one
  // serialisation of the whole world per interval, not one per edit; a lone edit goes out at once
  let sceneTimer: NodeJS.Timeout | null = null;
  let sceneSentAt = 0;
  const sendScene = (): void => {
    sceneTimer = null;
    sceneSentAt = Date.now();
    for (const slug of twins.keys()) broadcast(slug, "scene", sceneOf(slug));
  };
  const onScene = (): void => {
    if (sceneTimer) return;
    const wait = SCENE_INTERVAL_MS - (Date.now() - sceneSentAt);
    if (wait <= 0) sendScene();
    else sceneTimer = setTimeout(sendScene, wait);
  };
  world.on("scene", onScene);
  const detach: (() => void)[] = [
    () => {
      world.off("scene", onScene);
      if (sceneTimer) clearTimeout(sceneTimer);
    },
  ];
  for (const [slug, twin] of twins) {
    const onJoints = (m: object): void => broadcast(slug, "joints", m);
    const onStatus = (s: object): void => broadcast(slug, "status", { thing: slug, type: "status", ...s });
    const onCollision = (e: object): void => broadcast(slug, "collision", { thing: slug, type: "collision", ...e });
    const onDivergence = (e: object): void => broadcast(slug, "divergence", { thing: slug, type: "divergence", ...e });
    const onImminent = (e: object): void => broadcast(slug, "collisionImminent", { thing: slug, type: "collisionImminent", ...e });
    const onPhysical = (): void => {
      const state = twin.physical?.();
      if (state) broadcast(slug, "physical", { thing: slug, type: "physical", ...state });
    };
    twin.on("joints", onJoints);
    twin.on("status", onStatus);
    twin.on("collision", onCollision);
    twin.on("divergence", onDivergence);
    twin.on("collisionImminent", onImminent);
    twin.on("physical", onPhysical);
    detach.push(() => {
      twin.off("joints", onJoints);
      twin.off("status", onStatus);
      twin.off("collision", onCollision);
      twin.off("divergence", onDivergence);
      twin.off("collisionImminent", onImminent);
      twin.off("physical", onPhysical);
    });
  }

  /** `resume`: the last `seq` the client saw (its missed events are replayed first), null for none */
  const subscribe = (ws: WebSocket, slug: string, resume: number | null): void => {
    const client = clients.get(ws);
    if (!client) return;
    const targets = slug === "*" ? [...twins.keys()] : [slug];
    for (const s of targets) {
      const twin = twins.get(s);
      if (!twin) {
        send(ws, null, { type: "error", code: "E_UNKNOWN_THING", message: `no twin '${s}'`, details: { thing: s, available: [...twins.keys()] } }, false);
        continue;
      }
      if (resume !== null) {
        const { replay, gap } = kept.get(s)!.since(resume);
        if (gap) send(ws, null, { thing: s, type: "gap", resume, firstKept: gap.firstKept, reason: gap.reason }, false);
        for (const data of replay) client.queue.push(null, data);
      }
      client.things.add(s);
      send(ws, `joints:${s}`, twin.liveJoints());
      send(ws, `status:${s}`, { thing: s, type: "status", ...twin.status });
      send(ws, `scene:${s}`, sceneOf(s));
    }
  };

  /** A resume point the client gave but that is not a `seq` is refused: subscribing without it would lose events silently. */
  const subscribeResuming = (ws: WebSocket, slug: string, resume: unknown): void => {
    if (resume === undefined || resume === null) return subscribe(ws, slug, null);
    const point = typeof resume === "number" || typeof resume === "string" ? resumePoint(String(resume)) : null;
    if (point !== null) return subscribe(ws, slug, point);
    const message = `resume must be the seq of a message (a non-negative integer), got ${JSON.stringify(resume).slice(0, 40)}`;
    send(ws, null, { type: "error", code: "E_BAD_MESSAGE", message, details: { thing: slug } }, false);
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
      const body = JSON.stringify(e.problem());
      socket.end(`HTTP/1.1 ${e.status} ${e.code}\r\nContent-Type: ${PROBLEM_JSON}\r\nContent-Length: ${Buffer.byteLength(body)}\r\nConnection: close\r\n\r\n${body}`);
      return;
    }
    if (auth && !isAuthorized(req, auth)) {
      const scheme = auth.scheme === "basic" ? "Basic" : "Bearer";
      socket.end(`HTTP/1.1 401 Unauthorized\r\nWWW-Authenticate: ${scheme} realm="robwot"\r\nConnection: close\r\n\r\n`);
      return;
    }
    wss.handleUpgrade(req, socket, head, (ws) => {
      const peer = `/live ${req.socket.remoteAddress ?? "?"}:${req.socket.remotePort ?? "?"}`;
      clients.set(ws, { things: new Set(), queue: new PushQueue(wsTransport(ws), peer) });
      const gone = (): void => {
        clients.get(ws)?.queue.dispose();
        clients.delete(ws);
      };
      ws.on("close", gone);
      ws.on("error", gone);
      ws.on("message", (data) => {
        let msg: unknown;
        try {
          msg = JSON.parse(data.toString());
        } catch {
          send(ws, null, { type: "error", code: "E_BAD_JSON", message: "message is not JSON", details: {} }, false);
          return;
        }
        const m = (msg ?? {}) as { subscribe?: unknown; unsubscribe?: unknown; resume?: unknown };
        if (typeof m.subscribe === "string") subscribeResuming(ws, m.subscribe, m.resume);
        else if (typeof m.unsubscribe === "string") clients.get(ws)?.things.delete(m.unsubscribe);
        else {
          send(ws, null, { type: "error", code: "E_BAD_MESSAGE", message: 'expected {"subscribe": "<slug>", "resume"?: <seq>} or {"unsubscribe": "<slug>"}', details: {} }, false);
        }
      });
      const initial = url.searchParams.get("thing");
      if (initial) subscribeResuming(ws, initial, url.searchParams.get("resume") ?? undefined);
    });
  };
  server.on("upgrade", onUpgrade);

  return {
    clients: () => clients.size,
    close: async () => {
      server.off("upgrade", onUpgrade);
      detach.forEach((d) => d());
      for (const [ws, { queue }] of clients) {
        queue.dispose();
        ws.terminate();
      }
      await new Promise<void>((r) => wss.close(() => r()));
    },
  };
}
