/**
 * Clients that never read cost the servient a bounded amount of memory (issue 21): `robwot serve` in its
 * own process (its RSS read from /proc after a full garbage collection asked through the inspector, so
 * what is measured is what the servient holds, not garbage V8 has yet to collect; the Python backend is
 * a process apart), 100 raw TCP clients that send their
 * request — /live WebSocket upgrade, SSE stream, pipelined long-poll observations — and never read,
 * while the scene changes (large scene frames) and the robot moves. A slow /live client is closed with
 * code 1008 and the reason; a client that reads gets the latest scene. An SSE stream that is not read
 * ends with a comment saying why.
 */
import { spawn, type ChildProcess } from "node:child_process";
import { randomBytes } from "node:crypto";
import { readFileSync } from "node:fs";
import { createServer, type Server } from "node:http";
import { connect, type AddressInfo, type Socket } from "node:net";
import { afterAll, beforeAll, expect, it } from "vitest";
import WebSocket from "ws";
import { SseChannel, streamSse } from "../packages/servient/src/sse.js";
import { CLI } from "./cli-run.js";
import { generateTwin, invoke, kukaPose, live, sleep, waitFor, within, type LiveClient } from "./serve-helpers.js";

let serve: ChildProcess;
let inspector: WebSocket;
let info: { url: string; liveUrl: string; things: { slug: string }[] };
let base: string;
let port: number;
let slug: string;

beforeAll(async () => {
  const twin = await generateTwin("kuka_iiwa", 500);
  serve = spawn(process.execPath, ["--inspect=127.0.0.1:0", CLI, "serve", twin, "--port", "0", "--realtime", "0", "--json"], { stdio: ["ignore", "pipe", "pipe"] });
  let err = "";
  const inspectorUrl = new Promise<string>((resolve) =>
    serve.stderr!.on("data", (d: Buffer) => {
      err += d.toString();
      const m = /Debugger listening on (ws:\/\/\S+)/.exec(err);
      if (m) resolve(m[1]!);
    }),
  );
  info = await new Promise((resolve, reject) => {
    let out = "";
    serve.stdout!.on("data", (d: Buffer) => {
      out += d.toString();
      if (out.includes("\n")) resolve(JSON.parse(out.slice(0, out.indexOf("\n"))));
    });
    serve.once("exit", (code) => reject(new Error(`robwot serve exited with ${code}: ${err}`)));
  });
  inspector = new WebSocket(await inspectorUrl);
  await new Promise((resolve, reject) => (inspector.once("open", resolve), inspector.once("error", reject)));
  slug = info.things[0]!.slug;
  base = `${info.url}/${slug}`;
  port = Number(new URL(info.url).port);
}, 300_000);

afterAll(async () => {
  inspector?.close();
  if (serve && serve.exitCode === null) {
    serve.kill("SIGINT");
    await new Promise((r) => serve.once("exit", r));
  }
});

const rssMb = (): number => Number(/VmRSS:\s+(\d+)/.exec(readFileSync(`/proc/${serve.pid}/status`, "utf8"))?.[1]) / 1024;

let inspectorId = 0;
/** The servient's RSS after a full garbage collection (Chrome DevTools protocol, HeapProfiler.collectGarbage). */
async function rssAfterGcMb(): Promise<number> {
  const id = ++inspectorId;
  await new Promise<void>((resolve) => {
    const onMessage = (d: Buffer): void => {
      if ((JSON.parse(d.toString()) as { id?: number }).id !== id) return;
      inspector.off("message", onMessage);
      resolve();
    };
    inspector.on("message", onMessage);
    inspector.send(JSON.stringify({ id, method: "HeapProfiler.collectGarbage" }));
  });
  return rssMb();
}

/** Sends `request` and never reads: the socket is paused before the first byte arrives. */
function silent(request: string): Promise<Socket> {
  return new Promise((resolve, reject) => {
    const socket = connect(port, "127.0.0.1", () => {
      socket.write(request);
      socket.pause();
      resolve(socket);
    });
    socket.once("error", reject);
  });
}

const host = (): string => `Host: 127.0.0.1:${port}\r\n`;
const upgrade = (): string =>
  `GET /live?thing=${slug} HTTP/1.1\r\n${host()}Upgrade: websocket\r\nConnection: Upgrade\r\n` +
  `Sec-WebSocket-Key: ${randomBytes(16).toString("base64")}\r\nSec-WebSocket-Version: 13\r\n\r\n`;
const sseGet = (): string => `GET /${slug}/properties/getJointPosition/sse HTTP/1.1\r\n${host()}\r\n`;
const longPolls = (): string => `GET /${slug}/properties/getJointPosition/observable HTTP/1.1\r\n${host()}\r\n`.repeat(5);

/** Obstacles far from the robot (nothing collides) with long names: each scene frame is tens of kB. */
const NAMES = Array.from({ length: 150 }, (_, i) => `crate-${String(i).padStart(3, "0")}-${"x".repeat(120)}`);
const spot = (i: number, k: number): number[] => [3 + (i % 15) * 0.3, -3 + Math.floor(i / 15) * 0.3, 0.1 + 0.001 * (k % 100)];

/** Moves obstacles round-robin (two lanes) and the robot back and forth until `until()`; the last move. */
async function load(until: () => boolean): Promise<{ name: string; position: number[] }> {
  let last = { name: NAMES[0]!, position: spot(0, 0) };
  const lane = async (first: number): Promise<void> => {
    for (let k = first; !until(); k += 2) {
      const i = k % NAMES.length;
      const move = { name: NAMES[i]!, position: spot(i, k) };
      expect((await invoke(base, "moveObstacle", move)).status).toBe(200);
      last = move;
    }
  };
  const motion = async (): Promise<void> => {
    for (let k = 0; !until(); k++) expect((await invoke(base, "moveToJointPosition", { joints: kukaPose([k % 2 ? 0.5 : -0.5, 0, 0, -0.6]) })).status).toBe(200);
  };
  await Promise.all([lane(0), lane(1), motion()]);
  return last;
}

it("100 clients that never read cost the servient less than 20 MB; a slow /live client is closed with a reason; a reading client has the latest scene", async () => {
  for (const [i, name] of NAMES.entries()) {
    expect((await invoke(base, "addObstacle", { name, shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: spot(i, 0) })).status).toBe(200);
  }
  // the same load without clients first: the heap grows to what the load itself needs
  const warm = Date.now() + 3000;
  await load(() => Date.now() > warm);
  // a memory measurement spread over time on purpose: the servient's RSS settles after the load, then the
  // median of five samples is its idle size (no time is asserted)
  await sleep(1000);
  const idleSamples: number[] = [];
  for (let i = 0; i < 5; i++, await sleep(200)) idleSamples.push(await rssAfterGcMb());
  const idle = idleSamples.sort((a, b) => a - b)[2]!;

  const silentClients: Socket[] = [];
  for (let i = 0; i < 100; i++) silentClients.push(await silent(i % 10 < 6 ? upgrade() : i % 10 < 9 ? sseGet() : longPolls()));
  const reader: LiveClient = await live(`${info.liveUrl}?thing=${slug}`);
  const slow = new WebSocket(`${info.liveUrl}?thing=${slug}`);
  await new Promise((resolve, reject) => (slow.once("open", resolve), slow.once("error", reject)));
  const rawSlow = (slow as unknown as { _socket: Socket })._socket;
  rawSlow.pause();
  const closed = new Promise<{ code: number; reason: string }>((resolve) => slow.once("close", (code, reason) => resolve({ code, reason: reason.toString() })));

  let peak = idle;
  let runaway = false;
  const guard = setInterval(() => {
    // an unbounded servient would take the machine's memory: stop the load, the assertions below fail
    runaway ||= rssMb() - idle > 200;
  }, 200);
  const end = Date.now() + 20_000;
  const sampling = (async () => {
    while (Date.now() < end && !runaway) {
      // the sampling period of the peak under load
      await sleep(1000);
      peak = Math.max(peak, await rssAfterGcMb());
    }
  })();
  const last = await load(() => Date.now() > end || runaway);
  await sampling;
  clearInterval(guard);
  peak = Math.max(peak, await rssAfterGcMb());

  expect(runaway, "servient RSS grew past idle + 200 MB: the load was stopped").toBe(false);
  expect(peak - idle, `RSS idle ${idle.toFixed(1)} MB, peak ${peak.toFixed(1)} MB`).toBeLessThan(20);
  const latest = await reader.waitFor(
    (m) => m.type === "scene" && m.obstacles.some((o: { name: string; position: number[] }) => o.name === last.name && o.position.every((v, i) => Math.abs(v - last.position[i]!) < 1e-9)),
  );
  expect(latest.obstacles).toHaveLength(NAMES.length);
  reader.close();

  rawSlow.resume();
  const { code, reason } = await within(closed, "the slow /live client closed");
  expect(code).toBe(1008);
  expect(reason).toMatch(/^too slow: \d+ bytes unread for \d+ s$/);
  for (const s of silentClients) s.destroy();
}, 120_000);

it("an SSE stream its client does not read is ended with a comment saying why; values coalesce meanwhile", async () => {
  let timer: NodeJS.Timeout | null = null;
  let pushed = 0;
  let unsubscribed = false;
  // 60 values a second reach the queue at most: large ones fill the socket's kernel buffers in a second
  const value = "v".repeat(200_000);
  const server: Server = createServer((req, res) =>
    streamSse(
      req,
      res,
      new SseChannel("big", {
        current: () => ({ n: 0, value }),
        subscribe: (send) => {
          timer = setInterval(() => send({ n: ++pushed, value }), 1);
          return () => {
            clearInterval(timer!);
            unsubscribed = true;
          };
        },
      }),
      { highWater: 16 * 1024, maxEvents: 64, stallMs: 1500, closeGraceMs: 30_000 },
    ),
  );
  await new Promise<void>((r) => server.listen(0, "127.0.0.1", r));
  const { port: p } = server.address() as AddressInfo;
  const socket = connect(p, "127.0.0.1", () => socket.write(`GET /big HTTP/1.1\r\nHost: 127.0.0.1:${p}\r\n\r\n`));
  socket.pause();
  // the client reads nothing until the server has given up on it: its stream's values unsubscribed
  await waitFor(() => unsubscribed, { what: "the stalled stream ended by the server" });
  const chunks: Buffer[] = [];
  socket.on("data", (d: Buffer) => chunks.push(d));
  socket.resume();
  await waitFor(() => Buffer.concat(chunks).includes(": disconnected:"), { what: "the disconnect comment" }).catch(() => undefined);
  const text = Buffer.concat(chunks).toString();
  socket.destroy();
  server.closeAllConnections();
  await new Promise((r) => server.close(r));
  expect(text.startsWith("HTTP/1.1 200")).toBe(true);
  expect(text).toMatch(/: disconnected: too slow: \d+ bytes unread for \d+ s\n\n/);
  // the stream ended (chunked encoding's last chunk); its listener went with it (unsubscribed, awaited above)
  expect(text.endsWith("0\r\n\r\n")).toBe(true);
  const delivered = text.split("event: big\n").length - 1;
  expect(delivered).toBeGreaterThan(0);
  expect(delivered).toBeLessThan(pushed / 2);
}, 60_000);
