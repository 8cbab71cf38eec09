/**
 * Discovery (W3C WoT Discovery 1.0): the servient's introduction at `/.well-known/wot` and its read-only
 * Thing Description Directory, read by node-wot (a client we did not write) from the directory's TD and by
 * plain HTTP against the spec's listing rules (order, pagination Link headers, problem details); and
 * `--register`, tested against a directory stand-in written here from the TDD HTTP API: registration at
 * start, again after calibrate changed the TD, deregistration on stop. (No directory installs here from a
 * registry and works: domus-tdd-api 1.0.2 hands each TD to `node` as one command-line argument, beyond
 * the kernel's 128 KiB for our TDs, and its listing stayed empty after a 201 on this machine.)
 */
import { cpSync, readFileSync, writeFileSync } from "node:fs";
import { createServer, type Server } from "node:http";
import { dirname, join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { validateThingDescription } from "@robwot/core";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { consumer, generateTwin, http, invoke, waitFor } from "./serve-helpers.js";

let servient: RunningServient;

beforeAll(async () => {
  const a = await generateTwin("kuka_iiwa", 3000);
  // a second twin titled "things": its slug must not shadow the directory's /things
  const b = join(dirname(a), "things-titled");
  cpSync(a, b, { recursive: true });
  const td = JSON.parse(readFileSync(join(b, "td.json"), "utf8"));
  td.title = "things";
  writeFileSync(join(b, "td.json"), JSON.stringify(td));
  const manifest = JSON.parse(readFileSync(join(b, "twin.json"), "utf8"));
  manifest.robot.basePosition = [3, 0, 0];
  writeFileSync(join(b, "twin.json"), JSON.stringify(manifest));
  servient = await startServient({ twins: [a, b], port: 0, realtime: 0 });
}, 120_000);
afterAll(async () => servient?.stop());

const tdOf = async (tdUrl: string): Promise<Record<string, unknown>> => (await http(tdUrl)).body;

describe("the servient as a directory of its Things", () => {
  it("introduces itself at /.well-known/wot with a valid ThingDirectory TD", async () => {
    const r = await http(`${servient.url}/.well-known/wot`);
    expect(r.status).toBe(200);
    expect(r.headers.get("content-type")).toMatch(/^application\/td\+json/);
    expect(r.body["@type"]).toBe("ThingDirectory");
    expect(r.body["@context"]).toContain("https://www.w3.org/2022/wot/discovery");
    const v = await validateThingDescription(r.body);
    expect(v.errors).toEqual([]);
    expect(servient.things.map((t) => t.slug)).not.toContain("things");
  });

  it("node-wot reads the listing and retrieves each TD by id through the directory's TD", async () => {
    const served = await Promise.all(servient.things.map((t) => tdOf(t.tdUrl)));
    const wanted = served.map((t) => String(t["id"])).sort();
    const c = await consumer();
    try {
      const directory = await c.wot.consume((await c.wot.requestThingDescription(`${servient.url}/.well-known/wot`)) as WoT.ThingDescription);
      const things = (await (await directory.readProperty("things")).value()) as { id: string; title: string }[];
      expect(things.map((t) => t.id)).toEqual(wanted);
      for (const t of served) {
        const got = (await (await directory.invokeAction("retrieveThing", undefined, { uriVariables: { id: String(t["id"]) } }))!.value()) as { id: string; title: string };
        expect(got).toEqual(t);
      }
      const page = (await (await directory.readProperty("things", { uriVariables: { limit: 1, offset: 1 } })).value()) as { id: string }[];
      expect(page.map((t) => t.id)).toEqual([wanted[1]]);
    } finally {
      await c.stop();
    }
  });

  it("pages by limit with next and canonical Link headers, answers collections, refuses bad arguments as problems", async () => {
    const all = (await http(`${servient.url}/things`)).body as { id: string }[];
    expect(all).toHaveLength(2);
    const first = await http(`${servient.url}/things?limit=1`);
    expect(first.headers.get("content-type")).toMatch(/^application\/ld\+json/);
    expect(first.body.map((t: { id: string }) => t.id)).toEqual([all[0]!.id]);
    const links = first.headers.get("link") ?? "";
    expect(links).toContain('</things?offset=1&limit=1>; rel="next"');
    expect(links).toMatch(/<\/things>; rel="canonical"; etag="[0-9a-f]+"/);
    const last = await http(`${servient.url}/things?offset=1&limit=1`);
    expect(last.body.map((t: { id: string }) => t.id)).toEqual([all[1]!.id]);
    expect(last.headers.get("link")).not.toContain('rel="next"');
    const collection = (await http(`${servient.url}/things?format=collection&limit=1`)).body;
    expect(collection).toMatchObject({ "@type": "ThingCollection", total: 2, next: "/things?offset=1&limit=1&format=collection" });
    expect(collection.members).toHaveLength(1);
    for (const q of ["limit=0", "offset=-1", "limit=x", "format=csv"]) {
      const bad = await http(`${servient.url}/things?${q}`);
      expect(bad.status, q).toBe(400);
      expect(bad.headers.get("content-type"), q).toMatch(/^application\/problem\+json/);
    }
    const missing = await http(`${servient.url}/things/${encodeURIComponent("urn:nobody:here")}`);
    expect(missing.status).toBe(404);
    expect(missing.headers.get("content-type")).toMatch(/^application\/problem\+json/);
    expect((await http(`${servient.url}/things`, { method: "POST", body: "{}", headers: { "content-type": "application/td+json" } })).status).toBe(405);
  });
});

/** A Thing Description Directory stand-in: the TDD HTTP API's create/update (PUT), delete and listing. */
function standInDirectory(): Promise<{ url: string; server: Server; store: Map<string, unknown>; log: string[] }> {
  const store = new Map<string, unknown>();
  const log: string[] = [];
  const server = createServer((req, res) => {
    let body = "";
    req.on("data", (d: Buffer) => (body += d.toString()));
    req.on("end", () => {
      const path = new URL(req.url ?? "/", "http://x").pathname;
      const id = path.startsWith("/things/") ? decodeURIComponent(path.slice("/things/".length)) : null;
      log.push(`${req.method} ${path}`);
      if (req.method === "PUT" && id) {
        const td = JSON.parse(body) as { id?: string };
        if (req.headers["content-type"] !== "application/td+json" || td.id !== id) {
          res.writeHead(400, { "content-type": "application/problem+json" });
          return void res.end(JSON.stringify({ title: "bad registration", status: 400 }));
        }
        const created = !store.has(id);
        store.set(id, td);
        res.writeHead(created ? 201 : 204);
        return void res.end();
      }
      if (req.method === "DELETE" && id) {
        res.writeHead(store.delete(id) ? 204 : 404);
        return void res.end();
      }
      res.writeHead(200, { "content-type": "application/ld+json" });
      res.end(JSON.stringify([...store.values()]));
    });
  });
  return new Promise((ok) => server.listen(0, "127.0.0.1", () => ok({ url: `http://127.0.0.1:${(server.address() as { port: number }).port}`, server, store, log })));
}

describe("--register into a directory", () => {
  it("registers the TD at start, again after calibrate changed it, and deregisters it on stop", async () => {
    const tdd = await standInDirectory();
    const twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, register: tdd.url });
    try {
      const served = await tdOf(twin.things[0]!.tdUrl);
      const id = String(served["id"]);
      expect(tdd.log).toEqual([`PUT /things/${encodeURIComponent(id)}`]);
      expect(tdd.store.get(id)).toEqual(served);
      expect((await validateThingDescription(tdd.store.get(id))).errors).toEqual([]);
      // a calibration moves the Cartesian bounds into the real frame: the directory gets the new TD
      const virtual = [[0.3, 0, 0.4], [0, 0.3, 0.5], [-0.3, 0, 0.6], [0, -0.2, 0.3]];
      const pairs = virtual.map(([x, y, z]) => ({ virtual: { x, y, z }, real: { x: x! + 0.5, y, z } }));
      expect((await invoke(twin.things[0]!.tdUrl, "calibrate", { pairs, withScale: false })).status).toBe(200);
      const after = await tdOf(twin.things[0]!.tdUrl);
      expect(after).not.toEqual(served);
      await waitFor(() => JSON.stringify(tdd.store.get(id)) === JSON.stringify(after), { what: "the directory holding the calibrated TD" }).catch(() => undefined);
      expect(tdd.store.get(id)).toEqual(after);
    } finally {
      await twin.stop();
      tdd.server.close();
    }
    expect(tdd.log.at(-1)).toMatch(/^DELETE \/things\//);
    expect(tdd.store.size).toBe(0);
  }, 120_000);

  it("a directory that refuses is a warning, and the twin serves anyway", async () => {
    const refusing = createServer((_req, res) => {
      res.writeHead(503, { "content-type": "text/plain" });
      res.end("directory in maintenance");
    });
    await new Promise<void>((ok) => refusing.listen(0, "127.0.0.1", ok));
    const warnings: string[] = [];
    const onWarning = (w: Error): void => void warnings.push(w.message);
    process.on("warning", onWarning);
    try {
      const twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, register: `http://127.0.0.1:${(refusing.address() as { port: number }).port}` });
      try {
        expect((await http(twin.things[0]!.tdUrl)).status).toBe(200);
        const refused = /registering .* failed \(503 Service Unavailable: directory in maintenance\); retrying/;
        await waitFor(() => warnings.some((w) => refused.test(w)), { what: "the refusal warned about" }).catch(() => undefined);
        expect(warnings).toContainEqual(expect.stringMatching(refused));
      } finally {
        await twin.stop();
      }
    } finally {
      process.off("warning", onWarning);
      refusing.close();
    }
  }, 120_000);
});
