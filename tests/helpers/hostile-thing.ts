/**
 * A hostile (or merely broken) physical robot for end-to-end tests: a plain node:http server serving a WoT
 * TD with one joint-state property (`getJointPosition`, or a relay map's name) and one `stop` action, whose
 * answers the test changes at any time through `thing.td`, `thing.reading` and `thing.stop`:
 *
 *   const thing = await startHostileThing({ joints: { j1: 0, j2: 0 } });
 *   thing.reading = { kind: "hang", until: "stop" };    // hold every reading until a stop arrives
 *   thing.reading = { kind: "hang", ms: 500, once: true };  // hold the next one for 0.5 s
 *   thing.reading = { kind: "junk", body: '{"j1": "0x10"}' };
 *   thing.reading = { kind: "endless" };                 // a JSON body that never ends
 *   thing.stop = { kind: "hang" };                        // a stop held forever (`stops` still counts it)
 *
 * It counts what it was asked (`reads`, `inFlight`, `maxInFlight`, `stops`, `log`), and its joint state
 * schema accepts any JSON value, so what reaches the twin is what the twin itself must refuse (node-wot
 * checks a value against the TD's schema before the twin sees it). Bound to 127.0.0.1, port 0.
 */
import { createServer, type IncomingMessage, type ServerResponse } from "node:http";
import type { AddressInfo } from "node:net";

/** How the TD is served: as a TD, held forever, or as a body that never ends. */
export type TdMode = { kind: "ok" } | { kind: "hang" } | { kind: "endless" };

/** How a reading is answered. */
export type ReadingMode =
  /** `thing.joints` (or `value`, any JSON value) */
  | { kind: "joints"; value?: unknown }
  /** held: until `ms` passed, a stop arrived, or `release()`; then answered as `then` (default: the joints).
   *  `once`: only this request is held, the next ones are answered as `then` at once */
  | { kind: "hang"; until?: "stop" | "release"; ms?: number; then?: ReadingMode; once?: boolean }
  /** this body as it is, `application/json` (it need not be JSON) */
  | { kind: "junk"; body: string }
  /** a JSON array that never ends */
  | { kind: "endless" }
  | { kind: "status"; status: number };

export type StopMode = { kind: "ok" } | { kind: "hang" } | { kind: "status"; status: number };

export interface HostileThingOptions {
  /** what a `joints` reading answers: a record of joint -> value, or an array (a relay map's joint state) */
  joints: Record<string, number> | number[];
  title?: string;
  /** the joint state property's name (a relay map's `jointState`) */
  jointState?: string;
  /** the stop action's name (a relay map's `stop`) */
  stopAction?: string;
}

export interface HostileThing {
  url: string;
  tdUrl: string;
  /** what a `joints` reading answers */
  joints: Record<string, number> | number[];
  td: TdMode;
  reading: ReadingMode;
  stop: StopMode;
  /** stops received */
  stops: number;
  /** readings asked, held now, most held at once */
  reads: number;
  inFlight: number;
  maxInFlight: number;
  /** what happened, in order, with the server's time (ms, Date.now()) */
  log: { at: number; what: "read" | "stop" | "td" | "released" }[];
  /** answers every held reading now */
  release(): void;
  close(): Promise<void>;
}

export async function startHostileThing(o: HostileThingOptions): Promise<HostileThing> {
  const title = o.title ?? "hostile-robot";
  const jointState = o.jointState ?? "getJointPosition";
  const stopAction = o.stopAction ?? "stop";
  const held = new Set<{ answer: () => void; until?: "stop" | "release" }>();
  const sockets = new Set<import("node:net").Socket>();
  const endless = new Set<ServerResponse>();

  const json = (res: ServerResponse, status: number, body: string, type = "application/json"): void => {
    if (res.destroyed) return;
    res.writeHead(status, { "content-type": type, "content-length": Buffer.byteLength(body) });
    res.end(body);
  };
  const stream = (res: ServerResponse, type: string, open: string): void => {
    endless.add(res);
    res.writeHead(200, { "content-type": type });
    res.write(open);
    const chunk = "0,".repeat(32 * 1024);
    const more = (): void => {
      while (!res.destroyed && res.write(chunk));
      if (!res.destroyed) res.once("drain", more);
    };
    res.on("close", () => endless.delete(res));
    more();
  };

  const answer = (mode: ReadingMode, res: ServerResponse): void => {
    switch (mode.kind) {
      case "joints":
        return json(res, 200, JSON.stringify(mode.value !== undefined ? mode.value : thing.joints));
      case "junk":
        return json(res, 200, mode.body);
      case "endless":
        return stream(res, "application/json", "[");
      case "status":
        return json(res, mode.status, JSON.stringify({ error: `status ${mode.status}` }));
      case "hang": {
        if (mode.once) thing.reading = mode.then ?? { kind: "joints" };
        thing.inFlight++;
        thing.maxInFlight = Math.max(thing.maxInFlight, thing.inFlight);
        let timer: NodeJS.Timeout | undefined;
        const entry = {
          until: mode.until,
          answer: () => {
            if (!held.delete(entry)) return;
            clearTimeout(timer);
            thing.inFlight--;
            thing.log.push({ at: Date.now(), what: "released" });
            answer(mode.then ?? { kind: "joints" }, res);
          },
        };
        held.add(entry);
        if (mode.ms !== undefined) timer = setTimeout(entry.answer, mode.ms);
        res.on("close", () => {
          if (held.delete(entry)) {
            clearTimeout(timer);
            thing.inFlight--;
          }
        });
        return;
      }
    }
  };

  const handle = (req: IncomingMessage, res: ServerResponse): void => {
    const path = new URL(req.url ?? "/", "http://x").pathname;
    if (path === `/${title}` && req.method === "GET") {
      thing.log.push({ at: Date.now(), what: "td" });
      if (thing.td.kind === "hang") return;
      if (thing.td.kind === "endless") return stream(res, "application/td+json", `{"title": "${title}", "description": "`);
      return json(res, 200, JSON.stringify(td()), "application/td+json");
    }
    if (path === `/${title}/properties/${jointState}` && req.method === "GET") {
      thing.reads++;
      thing.log.push({ at: Date.now(), what: "read" });
      return answer(thing.reading, res);
    }
    if (path === `/${title}/actions/${stopAction}` && req.method === "POST") {
      thing.stops++;
      thing.log.push({ at: Date.now(), what: "stop" });
      for (const h of [...held]) if (h.until === "stop") h.answer();
      req.resume();
      if (thing.stop.kind === "hang") return;
      if (thing.stop.kind === "status") return json(res, thing.stop.status, JSON.stringify({ error: "refused" }));
      return json(res, 200, JSON.stringify({ stopped: true }));
    }
    json(res, 404, JSON.stringify({ error: "not found" }));
  };

  const server = createServer(handle);
  server.on("connection", (s) => {
    sockets.add(s);
    s.on("close", () => sockets.delete(s));
  });
  await new Promise<void>((resolve) => server.listen(0, "127.0.0.1", resolve));
  const url = `http://127.0.0.1:${(server.address() as AddressInfo).port}`;
  const any = { oneOf: ["object", "array", "string", "number", "boolean", "null"].map((type) => ({ type })) };
  const td = (): object => ({
    "@context": "https://www.w3.org/2019/wot/td/v1",
    title,
    id: `urn:robwot:test:${title}`,
    securityDefinitions: { nosec_sc: { scheme: "nosec" } },
    security: ["nosec_sc"],
    properties: {
      [jointState]: { ...any, readOnly: true, forms: [{ href: `${url}/${title}/properties/${jointState}`, op: ["readproperty"], contentType: "application/json" }] },
    },
    actions: {
      [stopAction]: { output: any, forms: [{ href: `${url}/${title}/actions/${stopAction}`, op: ["invokeaction"], contentType: "application/json" }] },
    },
  });

  const thing: HostileThing = {
    url,
    tdUrl: `${url}/${title}`,
    joints: Array.isArray(o.joints) ? [...o.joints] : { ...o.joints },
    td: { kind: "ok" },
    reading: { kind: "joints" },
    stop: { kind: "ok" },
    stops: 0,
    reads: 0,
    inFlight: 0,
    maxInFlight: 0,
    log: [],
    release: () => {
      for (const h of [...held]) h.answer();
    },
    close: async () => {
      thing.release();
      for (const res of endless) res.destroy();
      for (const s of sockets) s.destroy();
      await new Promise<void>((resolve) => server.close(() => resolve()));
    },
  };
  return thing;
}
