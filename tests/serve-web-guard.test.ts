/**
 * The web surface refuses what a hostile page or a rebound DNS name can send: foreign Origin (403),
 * wrong Host (421), non-JSON action bodies (415), CORS for other origins, /live upgrades from other
 * origins, node-wot's second route per Thing (404), bodies nested too deep (400). A configured
 * `--cors-origin` still works. Real servient, real backend, raw HTTP (to set Host) and real `ws`.
 */
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import WebSocket from "ws";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { rawRequest, type RawAnswer } from "./helpers/raw-http.js";
import { generateTwin, http, kukaPose } from "./serve-helpers.js";

let s: RunningServient;
let port: number;
let slug: string;
let twinDir: string;
const DASHBOARD = "https://dash.example:3000";
const FAR = kukaPose([0.4, 0.2, 0, -0.5, 0, 0.3, 0]);

beforeAll(async () => {
  twinDir = await generateTwin("kuka_iiwa", 3000);
  s = await startServient({ twins: [twinDir], port: 0, realtime: 0, corsOrigins: [DASHBOARD], allowedHosts: ["robot.lab"] });
  port = Number(new URL(s.url).port);
  slug = s.things[0]!.slug;
});
afterAll(async () => s?.stop());

/** One HTTP request to the servient with exactly the given headers. */
const raw = (method: string, path: string, headers: Record<string, string>, body?: string): Promise<RawAnswer> => rawRequest(port, method, path, headers, body);

const joints = async (): Promise<Record<string, number>> => (await http(`${s.url}/${slug}/properties/getJointPosition`)).body;
const move = (headers: Record<string, string>, body = JSON.stringify({ joints: FAR })): Promise<RawAnswer> =>
  raw("POST", `/${slug}/actions/moveToJointPosition`, headers, body);

describe("browsers of other origins", () => {
  it("a preflight from another origin is refused and grants nothing", async () => {
    const r = await raw("OPTIONS", `/${slug}/actions/moveToJointPosition`, {
      origin: "http://evil.example",
      "access-control-request-method": "POST",
      "access-control-request-headers": "content-type",
    });
    expect(r.status).toBe(403);
    expect(r.headers["access-control-allow-origin"]).toBeUndefined();
  });

  it("no response grants CORS to any origin (node-wot's `*` is gone)", async () => {
    for (const path of [`/${slug}`, `/${slug}/properties/getJointPosition`, "/"]) {
      const r = await raw("GET", path, { origin: "http://evil.example" });
      expect(r.status).toBe(200);
      expect(r.headers["access-control-allow-origin"]).toBeUndefined();
    }
  });

  it.each([
    ["application/json", JSON.stringify({ joints: FAR })],
    ["text/plain;charset=UTF-8", JSON.stringify({ joints: FAR })],
  ])("a command from another origin (%s) answers 403 and the twin does not move", async (type, body) => {
    const before = await joints();
    const r = await move({ origin: "http://evil.example", "content-type": type }, body);
    expect(r.status).toBe(403);
    expect(r.body.code).toBe("E_FORBIDDEN_ORIGIN");
    expect(await joints()).toEqual(before);
  });

  it("the opaque origin `null` (sandboxed frames, file://) is refused too", async () => {
    expect((await move({ origin: "null", "content-type": "application/json" })).status).toBe(403);
  });

  it("stop from another origin is refused as well", async () => {
    const r = await raw("POST", `/${slug}/actions/stop`, { origin: "http://evil.example" });
    expect(r.status).toBe(403);
  });
});

describe("action bodies are JSON by media type", () => {
  it.each([
    ["text/plain;charset=json"],
    ["text/plain"],
    ["application/x-www-form-urlencoded"],
    ["multipart/form-data; boundary=x"],
    ["application/jsonp"],
  ])("Content-Type %s answers 415 and the twin does not move", async (type) => {
    const before = await joints();
    const r = await move({ "content-type": type });
    expect(r.status).toBe(415);
    expect(r.body.code).toBe("E_UNSUPPORTED_MEDIA_TYPE");
    expect(await joints()).toEqual(before);
  });

  it("a body without Content-Type answers 415", async () => {
    expect((await move({})).status).toBe(415);
  });

  it("application/json with a charset and +json types are JSON", async () => {
    const r = await raw("POST", `/${slug}/actions/validateJointPosition`, { "content-type": "application/json; charset=utf-8" }, JSON.stringify({ joints: FAR }));
    expect(r.status).toBe(200);
    const t = await raw("POST", `/${slug}/actions/validateJointPosition`, { "content-type": "application/vnd.robwot+json" }, JSON.stringify({ joints: FAR }));
    expect(t.status).toBe(200);
  });
});

describe("Host must name the address served (DNS rebinding)", () => {
  it.each([["evil.example"], [`evil.example:${0}`], ["127.0.0.1:1"], ["localhost.evil.example"]])("Host %s answers 421 and nothing moves", async (host) => {
    const before = await joints();
    const r = await move({ host: host.replace(":0", `:${port}`), "content-type": "application/json" });
    expect(r.status).toBe(421);
    expect(r.body.code).toBe("E_MISDIRECTED");
    expect((await raw("GET", `/${slug}`, { host: host.replace(":0", `:${port}`) })).status).toBe(421);
    expect(await joints()).toEqual(before);
  });

  it.each([[`localhost:${"P"}`], [`127.0.0.1:${"P"}`], [`[::1]:${"P"}`], [`robot.lab:${"P"}`]])("loopback and --allowed-host names (%s) are served", async (host) => {
    const r = await raw("GET", `/${slug}`, { host: host.replace("P", String(port)) });
    expect(r.status).toBe(200);
  });

  it("an --allowed-host name is the twin's own origin too, on the served port only", async () => {
    const own = { host: `robot.lab:${port}`, origin: `http://robot.lab:${port}`, "content-type": "application/json" };
    expect((await raw("POST", `/${slug}/actions/validateJointPosition`, own, JSON.stringify({ joints: FAR }))).status).toBe(200);
    expect((await raw("GET", `/${slug}`, { host: "robot.lab:1" })).status).toBe(421);
    expect((await move({ ...own, origin: "http://robot.lab:1" })).status).toBe(403);
  });
});

describe("/live WebSocket", () => {
  const open = (headers: Record<string, string>, origin?: string): Promise<{ ok: boolean; status?: number }> =>
    new Promise((resolve) => {
      const ws = new WebSocket(`ws://127.0.0.1:${port}/live`, { headers, ...(origin ? { origin } : {}) });
      ws.once("open", () => {
        ws.close();
        resolve({ ok: true });
      });
      ws.once("unexpected-response", (_req, res) => resolve({ ok: false, status: res.statusCode }));
      ws.once("error", () => resolve({ ok: false }));
    });

  it("refuses an upgrade from another origin and from a foreign Host, accepts its own and plain clients", async () => {
    expect(await open({}, "http://evil.example")).toEqual({ ok: false, status: 403 });
    expect(await open({ host: "evil.example" })).toEqual({ ok: false, status: 421 });
    expect(await open({}, `http://127.0.0.1:${port}`)).toEqual({ ok: true });
    expect(await open({}, DASHBOARD)).toEqual({ ok: true });
    expect(await open({})).toEqual({ ok: true });
  });
});

describe("one HTTP surface per Thing", () => {
  it("node-wot's route under the Thing's id answers 404 JSON for the TD, properties and actions", async () => {
    const id = encodeURIComponent((await http(`${s.url}/${slug}`)).body.id);
    for (const [method, path] of [
      ["GET", `/${id}`],
      ["GET", `/${id}/properties/getJointPosition`],
      ["POST", `/${id}/actions/moveToJointPosition`],
    ] as const) {
      const r = await raw(method, path, { "content-type": "application/json" }, method === "POST" ? JSON.stringify({ joints: FAR }) : undefined);
      expect(r.status).toBe(404);
      expect(r.body.code).toBe("E_NOT_FOUND");
    }
  });
});

describe("only node-wot's affordance routes reach it, with their methods", () => {
  it.each([
    ["PUT", "properties/getJointPosition", "GET, HEAD"],
    ["PUT", "properties", "GET, HEAD"],
    ["POST", "", "GET, HEAD"],
    ["POST", "twin.json", "GET, HEAD"],
    ["POST", "events/collision", "GET, HEAD"],
    ["DELETE", "actions/stop", "POST"],
    ["PUT", "actions/moveToJointPosition", "POST"],
  ])("%s /<slug>/%s answers 405 JSON (Allow: %s) and nothing moves", async (method, rest, allow) => {
    const before = await joints();
    const r = await raw(method, `/${slug}/${rest}`, { "content-type": "application/json" }, JSON.stringify({ joints: FAR }));
    expect(r.status).toBe(405);
    expect(r.body.code).toBe("E_METHOD_NOT_ALLOWED");
    expect(r.headers["allow"]).toBe(allow);
    expect(await joints()).toEqual(before);
  });

  it.each([["actions"], ["actions/moveToJointPosition/.."], ["actions/stop/now"], ["events"], ["properties/motionStatus/x"]])(
    "POST /<slug>/%s (no such route) answers 404 JSON",
    async (rest) => {
      const r = await raw("POST", `/${slug}/${rest}`, { "content-type": "text/plain" }, "{}");
      expect(r.status).toBe(404);
      expect(r.body.code).toBe("E_NOT_FOUND");
    },
  );

  it("GET /<slug>/properties (readallproperties) still reaches node-wot, PUT does not (observe: serve.test.ts)", async () => {
    expect((await raw("GET", `/${slug}/properties`, {})).body.motionStatus.state).toBe("idle");
    expect((await raw("PUT", `/${slug}/properties`, { "content-type": "application/json" }, "{}")).body.code).toBe("E_METHOD_NOT_ALLOWED");
  });
});

describe("framing", () => {
  it("every page, the viewer included, may be framed only by the twin's own pages and --cors-origin pages", async () => {
    for (const path of ["/viewer/", `/${slug}`, `/${slug}/properties/motionStatus`]) {
      expect((await raw("GET", path, {})).headers["content-security-policy"]).toBe(`frame-ancestors 'self' ${DASHBOARD}`);
    }
  });
});

describe("values", () => {
  it("a body nested 20,000 deep answers 400 E_TOO_DEEP", async () => {
    const deep = "[".repeat(20_000) + "]".repeat(20_000);
    const r = await move({ "content-type": "application/json" }, deep);
    expect(r.status).toBe(400);
    expect(r.body.code).toBe("E_TOO_DEEP");
    expect((await http(`${s.url}/${slug}/properties/motionStatus`)).status).toBe(200);
  });
});

describe("--cors-origin", () => {
  it("grants CORS and commands to the configured dashboard", async () => {
    const pre = await raw("OPTIONS", `/${slug}/actions/moveToJointPosition`, {
      origin: DASHBOARD,
      "access-control-request-method": "POST",
      "access-control-request-headers": "content-type",
    });
    expect(pre.status).toBe(204);
    expect(pre.headers["access-control-allow-origin"]).toBe(DASHBOARD);
    const r = await move({ origin: DASHBOARD, "content-type": "application/json" });
    expect(r.status).toBe(200);
    expect(r.headers["access-control-allow-origin"]).toBe(DASHBOARD);
    expect(r.body.status).toBe("reached");
  });

  it("the twin's own origin (the viewer) may send commands", async () => {
    const r = await raw("POST", `/${slug}/actions/validateJointPosition`, { origin: `http://127.0.0.1:${port}`, "content-type": "application/json" }, JSON.stringify({ joints: FAR }));
    expect(r.status).toBe(200);
  });
});

describe("command line", () => {
  it.each([
    ["serve", "--cors-origin", "dash.example", /--cors-origin must be an origin/],
    ["serve", "--allowed-host", "robot.lab:80", /--allowed-host must be a host name/],
    ["demo", "--cors-origin", "https://dash.example/x", /--cors-origin must be an origin/],
    ["demo", "--allowed-host", "http://robot.lab", /--allowed-host must be a host name/],
  ])("%s %s %s exits 2 before any work", async (command, option, value, message) => {
    const tmp = mkdtempSync(join(tmpdir(), "robwot-web-guard-"));
    const out = join(tmp, "twin");
    const args = command === "serve" ? [twinDir, "--port", "0"] : ["--out", out, "--samples", "100"];
    const r = await runCli([command, ...args, option, value]);
    expect(r.code).toBe(2);
    expect(r.stderr).toMatch(message);
    expect(existsSync(out)).toBe(false);
    rmSync(tmp, { recursive: true, force: true });
  });
});
