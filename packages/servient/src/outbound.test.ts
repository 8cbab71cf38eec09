/**
 * The bounded transport of every request the servient makes to another Thing, against real HTTP servers
 * that misbehave: deadlines (connect, first byte, whole answer), the size cap, loops to itself, the
 * in-flight bound, credentials moved out of URLs, redirects not followed.
 */
import { createServer, type IncomingMessage, type Server, type ServerResponse } from "node:http";
import type { AddressInfo } from "node:net";
import { afterEach, describe, expect, it } from "vitest";
import { HOP_HEADER, LoopError, Outbound, OUTBOUND_LIMITS, redactUrl } from "./outbound.js";

const servers: Server[] = [];
afterEach(async () => {
  for (const s of servers.splice(0)) {
    s.closeAllConnections();
    await new Promise((r) => s.close(r));
  }
});

async function serve(handler: (req: IncomingMessage, res: ServerResponse) => void): Promise<string> {
  const s = createServer(handler);
  servers.push(s);
  await new Promise<void>((r) => s.listen(0, "127.0.0.1", r));
  return `http://127.0.0.1:${(s.address() as AddressInfo).port}`;
}

const limits = { ...OUTBOUND_LIMITS, connectMs: 300, firstByteMs: 300, totalMs: 600, invokeMs: 600, maxBytes: 64 * 1024, perTarget: 2 };

describe("Outbound.request", () => {
  it("answers a well-behaved peer, sends its hop token and a body", async () => {
    let seen: { hop?: string; body: string; method?: string } = { body: "" };
    const url = await serve((req, res) => {
      let body = "";
      req.on("data", (c: Buffer) => (body += c.toString()));
      req.on("end", () => {
        seen = { hop: req.headers[HOP_HEADER] as string, body, method: req.method };
        res.writeHead(201, { "Content-Type": "application/json" }).end('{"ok":true}');
      });
    });
    const out = new Outbound(limits);
    const a = await out.request(`${url}/x`, { method: "PUT", body: '{"a":1}' });
    expect(a.status).toBe(201);
    expect(JSON.parse(a.body.toString())).toEqual({ ok: true });
    expect(seen).toEqual({ hop: out.token, body: '{"a":1}', method: "PUT" });
    out.close();
  });

  it.each([
    ["a peer that never answers", "no answer within 300 ms", (_req: IncomingMessage, _res: ServerResponse) => undefined],
    ["headers then a body that never ends", "no complete answer within 600 ms", (_req: IncomingMessage, res: ServerResponse) => void res.writeHead(200).write("{")],
  ])("fails on %s, naming the deadline", async (_what, why, handler) => {
    const url = await serve(handler);
    const out = new Outbound(limits);
    await expect(out.request(`${url}/hang`)).rejects.toThrow(why);
    out.close();
  });

  it("cuts an endless answer at the size cap instead of buffering it", async () => {
    let written = 0;
    const url = await serve((_req, res) => {
      res.writeHead(200, { "Content-Type": "application/json" });
      const chunk = Buffer.alloc(16 * 1024, 32);
      const pump = (): void => {
        while (!res.destroyed) {
          written += chunk.length;
          if (!res.write(chunk)) break;
        }
        if (!res.destroyed) res.once("drain", pump);
      };
      pump();
    });
    const out = new Outbound({ ...limits, totalMs: 5_000 });
    await expect(out.request(`${url}/endless`)).rejects.toThrow(`answer larger than ${limits.maxBytes} bytes`);
    out.close();
    // the peer went on writing past the cap: the cut was ours
    expect(written).toBeGreaterThan(limits.maxBytes);
  });

  it("refuses at once an answer whose declared length passes the cap", async () => {
    const url = await serve((_req, res) => void res.writeHead(200, { "Content-Length": String(10 * limits.maxBytes) }).write("x"));
    const out = new Outbound(limits);
    await expect(out.request(`${url}/big`)).rejects.toThrow(`answer of ${10 * limits.maxBytes} bytes is larger than ${limits.maxBytes}`);
    out.close();
  });

  it("refuses a request to its own listening address, by any name that resolves to it", async () => {
    const url = await serve((_req, res) => void res.end("{}"));
    const port = Number(new URL(url).port);
    const out = new Outbound(limits);
    out.listening("127.0.0.1", port);
    await expect(out.request(`${url}/actions/stop`, { method: "POST" })).rejects.toBeInstanceOf(LoopError);
    await expect(out.request(`http://localhost:${port}/x`)).rejects.toThrow(/this servient itself|ECONNREFUSED/);
    await expect(out.refuseSelf(`http://127.0.0.1:${port}/twin`, "--relay")).rejects.toThrow(`--relay http://127.0.0.1:${port}/twin is this servient itself`);
    // bound to every interface: a loopback address is itself too
    out.listening("0.0.0.0", port);
    await expect(out.request(`http://127.0.0.1:${port}/x`)).rejects.toBeInstanceOf(LoopError);
    // another port is another server
    await expect(out.refuseSelf(`http://127.0.0.1:${port + 1}/twin`, "--relay")).resolves.toBeUndefined();
    out.close();
  });

  it("refuses a TD one of whose forms points back at it", async () => {
    const out = new Outbound(limits);
    out.listening("127.0.0.1", 4567);
    const td = { base: "http://127.0.0.1:9/robot/", actions: { stop: { forms: [{ href: "http://127.0.0.1:4567/twin/actions/stop" }] } }, properties: { q: { forms: [{ href: "properties/q" }] } } };
    await expect(out.refuseSelfForms(td, "http://127.0.0.1:9/robot", "--relay")).rejects.toThrow("--relay: the form of actions/stop at http://127.0.0.1:4567/twin/actions/stop is this servient itself");
    await expect(out.refuseSelfForms({ ...td, actions: {} }, "http://127.0.0.1:9/robot", "--relay")).resolves.toBeUndefined();
    out.close();
  });

  it("bounds the requests in flight to one URL, and frees the slot when one ends", async () => {
    const url = await serve((req, res) => {
      if (req.url === "/fast") res.end("{}");
    });
    const out = new Outbound({ ...limits, firstByteMs: 2_000, totalMs: 2_000 });
    const hung = [out.request(`${url}/slow`), out.request(`${url}/slow`)];
    await expect(out.request(`${url}/slow`)).rejects.toThrow("2 requests already in flight (at most 2)");
    // another URL of the same peer is not held up
    expect((await out.request(`${url}/fast`)).status).toBe(200);
    await Promise.allSettled(hung);
    await expect(out.request(`${url}/slow`)).rejects.toThrow(/answer within 2000 ms/);
    out.close();
  });

  it("moves URL credentials into an Authorization header of that origin and shows the URL without them", async () => {
    const auths: (string | undefined)[] = [];
    const url = await serve((req, res) => {
      auths.push(req.headers.authorization);
      res.end("{}");
    });
    const out = new Outbound(limits);
    const withUser = url.replace("http://", "http://robot:s%3Acret@");
    const clean = out.authorize(withUser);
    expect(clean).toBe(`${url}/`);
    expect(redactUrl(`${withUser}/td`)).toBe(`${url}/td`);
    await out.request(`${url}/properties/q`);
    const basic = `Basic ${Buffer.from("robot:s:cret").toString("base64")}`;
    expect(auths).toEqual([basic]);
    out.close();
  });

  it("does not follow a redirect: the 3xx is the answer", async () => {
    let followed = false;
    const url = await serve((req, res) => {
      if (req.url === "/elsewhere") followed = true;
      res.writeHead(302, { Location: "/elsewhere" }).end();
    });
    const out = new Outbound(limits);
    expect((await out.request(`${url}/td`)).status).toBe(302);
    expect(followed).toBe(false);
    out.close();
  });
});
