/**
 * A misbehaving peer for the twin's outbound requests: an HTTP server in front of a real Thing (a servient
 * standing in for the physical robot) that forwards every request to it, rewriting the Thing's origin in
 * answers (its TD's forms then point at the proxy), unless `route` takes the request over: hold it forever,
 * answer an endless body, change the TD. It counts what it saw, by method and path.
 */
import { once } from "node:events";
import { createServer, request, type IncomingMessage, type Server, type ServerResponse } from "node:http";

/** What to do with one request: forward it (optionally rewriting the TD answered), or answer it here. */
export type Route = "forward" | ((req: IncomingMessage, res: ServerResponse, body: Buffer) => void) | { td: (td: any) => any };

export interface PeerProxy {
  url: string;
  /** requests seen, as "METHOD /path" */
  seen: string[];
  count(pattern: RegExp): number;
  close(): Promise<void>;
}

export async function peerProxy(target: string, route: (req: IncomingMessage) => Route = () => "forward"): Promise<PeerProxy> {
  const t = new URL(target);
  let self = "";
  const seen: string[] = [];
  const server: Server = createServer((req, res) => {
    seen.push(`${req.method} ${req.url}`);
    const chunks: Buffer[] = [];
    req.on("data", (c: Buffer) => chunks.push(c));
    req.on("end", () => {
      const body = Buffer.concat(chunks);
      const how = route(req);
      if (typeof how === "function") return how(req, res, body);
      const headers = { ...req.headers, host: t.host };
      const up = request({ host: t.hostname, port: t.port, method: req.method, path: req.url, headers }, (answer) => {
        const parts: Buffer[] = [];
        answer.on("data", (c: Buffer) => parts.push(c));
        answer.on("end", () => {
          let text = Buffer.concat(parts).toString("utf8").replaceAll(t.origin, self);
          if (typeof how === "object") text = JSON.stringify(how.td(JSON.parse(text)));
          const out = { ...answer.headers };
          delete out["content-length"];
          res.writeHead(answer.statusCode ?? 502, out);
          res.end(text);
        });
      });
      up.on("error", () => res.destroy());
      up.end(body);
    });
  });
  server.listen(0, "127.0.0.1");
  await once(server, "listening");
  self = `http://127.0.0.1:${(server.address() as { port: number }).port}`;
  return {
    url: self,
    seen,
    count: (pattern) => seen.filter((s) => pattern.test(s)).length,
    close: async () => {
      server.closeAllConnections();
      await new Promise((r) => server.close(r));
    },
  };
}

/** Answers with headers and then a JSON body that never ends (until the client goes). */
export function endless(_req: IncomingMessage, res: ServerResponse): void {
  res.writeHead(200, { "Content-Type": "application/json" });
  res.write("[");
  const chunk = Buffer.alloc(64 * 1024, "0,".repeat(32 * 1024));
  const pump = (): void => {
    while (!res.destroyed && res.write(chunk));
    if (!res.destroyed) res.once("drain", pump);
  };
  pump();
}

/** Never answers. */
export function hang(): void {}
