/**
 * The `/live` WebSocket (Contract 4), plain `ws` on node-wot's own HTTP server (`upgrade` event).
 * Client -> server: `{"subscribe": "<slug>"}` (or `"*"` for every twin), `{"unsubscribe": "<slug>"}`;
 * `ws://host:port/live?thing=<slug>` subscribes at once. Server -> client:
 * `{thing, type: "joints", time, joints, position, orientation}` (>= 30 Hz of simulated time while moving),
 * `{thing, type: "status", ...motionStatus}`, `{thing, type: "collision", ...collision event}`,
 * `{thing, type: "scene", obstacles, objects}` (the shared world's obstacles in scene.json's shape and its
 * objects where they rest, after every scene edit (object poses change only by one); edits in a burst share one frame, at most 30 per second, the last one always reflecting the
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
import type { SceneRecord } from "./scene-record.js";

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

type Kind = "joints" | "status" | "scene" | "collision" | "divergence" | "collisionImminent" | "physical";
/** the twin's events a /live client is told of (kept for resuming clients), besides its states */
const EVENTS = new Set<Kind>(["collision", "divergence", "collisionImminent"]);

/** Refuses an upgrade that is not to `/live` or that the guards or auth refuse; true when refused. */
function refuseUpgrade(req: IncomingMessage, socket: Duplex, url: URL, auth: AuthConfig | undefined, guard: RequestGuard): boolean {
  if (url.pathname !== "/live") {
    socket.end("HTTP/1.1 404 Not Found\r\nConnection: close\r\n\r\n");
    return true;
  }
  try {
    // a page of another origin must not even watch (it could time its commands on what it sees)
    guard.checkHost(req);
    guard.checkOrigin(req, true);
  } catch (err) {
    const e = err as ServientError;
    const body = JSON.stringify(e.problem());
    socket.end(`HTTP/1.1 ${e.status} ${e.code}\r\nContent-Type: ${PROBLEM_JSON}\r\nContent-Length: ${Buffer.byteLength(body)}\r\nConnection: close\r\n\r\n${body}`);
    return true;
  }
  if (auth && !isAuthorized(req, auth)) {
    const scheme = auth.scheme === "basic" ? "Basic" : "Bearer";
    socket.end(`HTTP/1.1 401 Unauthorized\r\nWWW-Authenticate: ${scheme} realm="robwot"\r\nConnection: close\r\n\r\n`);
    return true;
  }
  return false;
}

/** The /live clients of one servient, what they subscribed to, and the stream they are sent. */
class LiveHub {
  private readonly wss = new WebSocketServer({ noServer: true, maxPayload: 64 * 1024 });
  readonly clients = new Map<WebSocket, { things: Set<string>; queue: PushQueue<Buffer> }>();
  /** one sequence for every message of the stream; the events of each twin kept for resuming clients */
  private readonly seq = new Sequence();
  private readonly kept: Map<string, EventHistory<Buffer>>;
  private readonly detach: (() => void)[] = [];
  private sceneTimer: NodeJS.Timeout | null = null;
  private sceneSentAt = 0;

  constructor(
    private readonly twins: Map<string, Twin>,
    private readonly world: SceneRecord,
  ) {
    this.kept = new Map([...twins.keys()].map((slug) => [slug, new EventHistory<Buffer>(this.seq)]));
    const onScene = (): void => this.onScene();
    world.on("scene", onScene);
    this.detach.push(() => {
      world.off("scene", onScene);
      if (this.sceneTimer) clearTimeout(this.sceneTimer);
    });
    for (const [slug, twin] of twins) this.watch(slug, twin);
  }

  private stamp(msg: object, n: number): Buffer {
    return Buffer.from(JSON.stringify({ ...msg, seq: n }));
  }

  /** key: what the message coalesces with (`<kind>:<slug>`), null for an event or a reply (kept) */
  send(ws: WebSocket, key: string | null, msg: object, numbered = true): void {
    this.clients.get(ws)?.queue.push(key, numbered ? this.stamp(msg, this.seq.take()) : Buffer.from(JSON.stringify(msg)));
  }

  private broadcast(slug: string, kind: Kind, msg: object): void {
    let data: Buffer | null = null;
    // events are kept (up to a bound, also here for resuming clients); of a state, the latest replaces a queued one
    const event = EVENTS.has(kind);
    if (event) data = this.kept.get(slug)!.record((n) => this.stamp(msg, n));
    const key = event ? null : `${kind}:${slug}`;
    for (const { things, queue } of this.clients.values()) {
      if (!things.has(slug)) continue;
      data ??= this.stamp(msg, this.seq.take());
      queue.push(key, data);
    }
  }

  private sceneOf(slug: string): object {
    // a world with conveyors: their belts too (scene.json's shape, state now; `cell-record.ts`)
    const conveyors = this.world.cell.conveyors.size > 0 ? { conveyors: [...this.world.cell.conveyors.values()] } : {};
    return { thing: slug, type: "scene", obstacles: this.world.sceneObstacles(), objects: this.world.sceneObjects(), ...conveyors };
  }

  /** at most one scene frame per SCENE_INTERVAL_MS, the latest scene: a burst of edits costs one
   *  serialisation of the whole world per interval, not one per edit; a lone edit goes out at once */
  private onScene(): void {
    if (this.sceneTimer) return;
    const sendScene = (): void => {
      this.sceneTimer = null;
      this.sceneSentAt = Date.now();
      for (const slug of this.twins.keys()) this.broadcast(slug, "scene", this.sceneOf(slug));
    };
    const wait = SCENE_INTERVAL_MS - (Date.now() - this.sceneSentAt);
    if (wait <= 0) sendScene();
    else this.sceneTimer = setTimeout(sendScene, wait);
  }

  /** The twin's states and events, to the clients subscribed to it. */
  private watch(slug: string, twin: Twin): void {
    const listeners: [Parameters<Twin["on"]>[0], (e: object) => void][] = [
      ["joints", (m) => this.broadcast(slug, "joints", m)],
      ["status", (s) => this.broadcast(slug, "status", { thing: slug, type: "status", ...s })],
      ...[...EVENTS].map((kind): [Parameters<Twin["on"]>[0], (e: object) => void] => [kind as Parameters<Twin["on"]>[0], (e) => this.broadcast(slug, kind, { thing: slug, type: kind, ...e })]),
      [
        "physical",
        () => {
          const state = twin.physical?.();
          if (state) this.broadcast(slug, "physical", { thing: slug, type: "physical", ...state });
        },
      ],
    ];
    for (const [event, fn] of listeners) twin.on(event, fn as never);
    this.detach.push(() => listeners.forEach(([event, fn]) => twin.off(event, fn as never)));
  }

  /** `resume`: the last `seq` the client saw (its missed events are replayed first), null for none */
  private subscribe(ws: WebSocket, slug: string, resume: number | null): void {
    const client = this.clients.get(ws);
    if (!client) return;
    for (const s of slug === "*" ? [...this.twins.keys()] : [slug]) {
      const twin = this.twins.get(s);
      if (!twin) {
        this.send(ws, null, { type: "error", code: "E_UNKNOWN_THING", message: `no twin '${s}'`, details: { thing: s, available: [...this.twins.keys()] } }, false);
        continue;
      }
      if (resume !== null) {
        const { replay, gap } = this.kept.get(s)!.since(resume);
        if (gap) this.send(ws, null, { thing: s, type: "gap", resume, firstKept: gap.firstKept, reason: gap.reason }, false);
        for (const data of replay) client.queue.push(null, data);
      }
      client.things.add(s);
      this.send(ws, `joints:${s}`, twin.liveJoints());
      this.send(ws, `status:${s}`, { thing: s, type: "status", ...twin.status });
      this.send(ws, `scene:${s}`, this.sceneOf(s));
    }
  }

  /** A resume point the client gave but that is not a `seq` is refused: subscribing without it would lose events silently. */
  subscribeResuming(ws: WebSocket, slug: string, resume: unknown): void {
    if (resume === undefined || resume === null) return this.subscribe(ws, slug, null);
    const point = typeof resume === "number" || typeof resume === "string" ? resumePoint(String(resume)) : null;
    if (point !== null) return this.subscribe(ws, slug, point);
    const message = `resume must be the seq of a message (a non-negative integer), got ${JSON.stringify(resume).slice(0, 40)}`;
    this.send(ws, null, { type: "error", code: "E_BAD_MESSAGE", message, details: { thing: slug } }, false);
  }

  /** A client's message: subscribe (resuming) or unsubscribe; anything else an error reply. */
  private onMessage(ws: WebSocket, data: Buffer): void {
    let msg: unknown;
    try {
      msg = JSON.parse(data.toString());
    } catch {
      return this.send(ws, null, { type: "error", code: "E_BAD_JSON", message: "message is not JSON", details: {} }, false);
    }
    const m = (msg ?? {}) as { subscribe?: unknown; unsubscribe?: unknown; resume?: unknown };
    if (typeof m.subscribe === "string") this.subscribeResuming(ws, m.subscribe, m.resume);
    else if (typeof m.unsubscribe === "string") this.clients.get(ws)?.things.delete(m.unsubscribe);
    else this.send(ws, null, { type: "error", code: "E_BAD_MESSAGE", message: 'expected {"subscribe": "<slug>", "resume"?: <seq>} or {"unsubscribe": "<slug>"}', details: {} }, false);
  }

  /** Takes an upgrade the guards let through: the client, its queue, its messages, its first subscription. */
  accept(req: IncomingMessage, socket: Duplex, head: Buffer, url: URL): void {
    this.wss.handleUpgrade(req, socket, head, (ws) => {
      const peer = `/live ${req.socket.remoteAddress ?? "?"}:${req.socket.remotePort ?? "?"}`;
      this.clients.set(ws, { things: new Set(), queue: new PushQueue(wsTransport(ws), peer) });
      const gone = (): void => {
        this.clients.get(ws)?.queue.dispose();
        this.clients.delete(ws);
      };
      ws.on("close", gone);
      ws.on("error", gone);
      ws.on("message", (data) => this.onMessage(ws, data as Buffer));
      const initial = url.searchParams.get("thing");
      if (initial) this.subscribeResuming(ws, initial, url.searchParams.get("resume") ?? undefined);
    });
  }

  async close(): Promise<void> {
    this.detach.forEach((d) => d());
    for (const [ws, { queue }] of this.clients) {
      queue.dispose();
      ws.terminate();
    }
    await new Promise<void>((r) => this.wss.close(() => r()));
  }
}

export function attachLive(server: Server, twins: Map<string, Twin>, world: SceneRecord, auth: AuthConfig | undefined, guard: RequestGuard): LiveServer {
  const hub = new LiveHub(twins, world);
  const onUpgrade = (req: IncomingMessage, socket: Duplex, head: Buffer): void => {
    const url = new URL(req.url ?? "/", "http://localhost");
    if (!refuseUpgrade(req, socket, url, auth, guard)) hub.accept(req, socket, head, url);
  };
  server.on("upgrade", onUpgrade);
  return {
    clients: () => hub.clients.size,
    close: async () => {
      server.off("upgrade", onUpgrade);
      await hub.close();
    },
  };
}
