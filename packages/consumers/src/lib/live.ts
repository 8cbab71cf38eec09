/**
 * The servient's plain WebSocket live stream (ARCHITECTURE.md Contract 4), with no node-wot:
 * connect to `ws://host:port/live`, send `{"subscribe": "<slug>"}`, receive JSON messages
 * `{"thing", "type": "joints"|"status"|"collision", ...}`.
 *
 * The endpoint comes from the TD's WebSocket form; if the TD has none, from `GET /robwot.json`
 * on the TD's origin (a field holding a ws:// URL).
 */
import WebSocket from "ws";
import { authHeaders, fetchOk, type Twin } from "./connect.js";
import { liveUrl, slugOf } from "@robwot/core";

export interface LiveMessage {
  thing: string;
  type: "joints" | "status" | "collision" | string;
  time?: number;
  joints?: Record<string, number>;
  position?: { x: number; y: number; z: number };
  [key: string]: unknown;
}

function findWsUrl(value: unknown): string | undefined {
  if (typeof value === "string") return /^wss?:\/\//i.test(value) ? value : undefined;
  if (value !== null && typeof value === "object") {
    for (const v of Object.values(value as Record<string, unknown>)) {
      const hit = findWsUrl(v);
      if (hit !== undefined) return hit;
    }
  }
  return undefined;
}

/** Where to connect for live updates of `twin`. */
export async function resolveLiveUrl(twin: Twin): Promise<string> {
  const fromTd = liveUrl(twin.td);
  if (fromTd !== undefined) return fromTd;
  const info = new URL("/robwot.json", twin.url).toString();
  const found = findWsUrl(await (await fetchOk(info, twin.auth)).json());
  if (found === undefined) throw new Error(`neither the TD at ${twin.url} nor ${info} advertises a WebSocket endpoint`);
  return found;
}

export interface LiveSubscription {
  url: string;
  close(): Promise<void>;
}

/** Subscribe to the twin's live stream; resolves once the socket is open and the subscribe is sent. */
export async function subscribeLive(
  twin: Twin,
  onMessage: (msg: LiveMessage) => void,
  onError: (err: Error) => void,
): Promise<LiveSubscription> {
  const url = await resolveLiveUrl(twin);
  const slug = slugOf(twin.url);
  const socket = new WebSocket(url, { headers: authHeaders(twin.auth) });
  await new Promise<void>((resolve, reject) => {
    socket.once("open", () => resolve());
    socket.once("error", (err) => reject(new Error(`WebSocket ${url}: ${err.message}`)));
    socket.once("unexpected-response", (_req, res) =>
      reject(new Error(`WebSocket ${url} answered HTTP ${res.statusCode ?? "?"} instead of upgrading`)),
    );
  });
  socket.on("error", (err) => onError(err));
  socket.on("message", (data) => {
    let msg: unknown;
    try {
      msg = JSON.parse(data.toString());
    } catch {
      onError(new Error(`live message is not JSON: ${data.toString().slice(0, 80)}`));
      return;
    }
    if (msg !== null && typeof msg === "object") onMessage(msg as LiveMessage);
  });
  socket.send(JSON.stringify({ subscribe: slug }));
  return {
    url,
    close: () =>
      new Promise<void>((resolve) => {
        if (socket.readyState === WebSocket.CLOSED) return resolve();
        socket.once("close", () => resolve());
        socket.close();
        setTimeout(() => {
          socket.terminate();
          resolve();
        }, 1000).unref();
      }),
  };
}
