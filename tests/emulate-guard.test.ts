/**
 * `robwot emulate` is guarded as the twin is: a jog from a foreign Origin (403) or under a foreign Host
 * (421, DNS rebinding) does not move it; CORS only for `--cors-origin`, never `*`; bad input answers 4xx
 * problem details (never 500); a streamed body past the servient's cap answers 413 without being read on
 * or buffered; only the emulated Thing's routes reach node-wot; binding a non-loopback address without
 * --auth is warned about. Real emulator (its own backend), raw HTTP (to set Host) and fetch.
 */
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { MAX_BODY } from "../packages/servient/src/http-middleware.js";
import { startEmulator, type RunningEmulator } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { rawRequest, type RawAnswer } from "./helpers/raw-http.js";
import { generateTwin, http, invoke, kukaPose, waitState } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
const DASHBOARD = "https://dash.example:3000";
const PROBLEM = "application/problem+json";
/** TEST-NET-1 (RFC 5737): not an address of this machine, so binding it fails after the warning */
const NOT_LOOPBACK = "192.0.2.1";
let dir: string;
let robot: RunningEmulator;
let port: number;
let path: string;

beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
  robot = await startEmulator({ folder: dir, port: 0, corsOrigins: [DASHBOARD] });
  port = Number(new URL(robot.url).port);
  path = new URL(robot.tdUrl).pathname;
});
afterAll(async () => robot?.stop());

/** One HTTP request to the emulator with exactly the given headers. */
const raw = (method: string, to: string, headers: Record<string, string>, body?: string): Promise<RawAnswer> => rawRequest(port, method, to, headers, body);

const joints = async (): Promise<Record<string, number>> => (await http(`${robot.tdUrl}/properties/getJointPosition`)).body;
const JOG = JSON.stringify({ velocities: { [J1]: 0.5 }, duration: 0.2 });

/** Sends `send` and checks that the robot did not move. A command runs from its acceptance until the
 * answer that ends it, so once the refusal is answered nothing runs: stop finds no motion to end and the
 * joints are those before. */
async function stillAfter(send: () => Promise<RawAnswer>): Promise<RawAnswer> {
  const before = await joints();
  const r = await send();
  expect((await invoke(robot.tdUrl, "stop", "")).body).toEqual({ stopped: false });
  expect(await joints()).toEqual(before);
  expect((await http(`${robot.tdUrl}/properties/motionStatus`)).body.state).not.toBe("moving");
  return r;
}

describe("a web page or a rebound DNS name", () => {
  it.each([
    ["a foreign Origin", { origin: "http://evil.example" }, 403, "E_FORBIDDEN_ORIGIN"],
    ["the literal null Origin (sandboxed frame)", { origin: "null" }, 403, "E_FORBIDDEN_ORIGIN"],
    ["a foreign Origin and Host (DNS rebinding)", { origin: "http://evil.example", host: "evil.example" }, 421, "E_MISDIRECTED"],
    ["a foreign Host with the served port", { host: "evil.example:PORT" }, 421, "E_MISDIRECTED"],
    ["the right name with another port", { host: "127.0.0.1:1" }, 421, "E_MISDIRECTED"],
  ])("a jog with %s is refused and the robot does not move", async (_what, headers, status, code) => {
    const h = Object.fromEntries(Object.entries(headers).map(([k, v]) => [k, v.replace("PORT", String(port))]));
    const r = await stillAfter(() => raw("POST", `${path}/actions/jog`, { "content-type": "application/json", ...h }, JOG));
    expect(r.status, JSON.stringify(r.body)).toBe(status);
    expect(r.headers["content-type"]).toBe(PROBLEM);
    expect(r.body.code).toBe(code);
    // the refusal names the emulator's own option
    expect(r.body.detail).toMatch(/start emulate with --(cors-origin|allowed-host)/);
  });

  it("a jog from its own origin or a --cors-origin page moves it", async () => {
    const from = (await joints())[J1]!;
    const own = await raw("POST", `${path}/actions/jog`, { "content-type": "application/json", origin: `http://127.0.0.1:${port}` }, JOG);
    expect(own.status, JSON.stringify(own.body)).toBe(200);
    const dash = await raw("POST", `${path}/actions/jog`, { "content-type": "application/json", origin: DASHBOARD }, JOG);
    expect(dash.status).toBe(200);
    expect(dash.headers["access-control-allow-origin"]).toBe(DASHBOARD);
    expect((await joints())[J1]! - from).toBeCloseTo(0.2, 1);
  });

  it("grants CORS to no other origin, never *; preflights from other origins answer 403", async () => {
    for (const to of [path, `${path}/properties/getJointPosition`]) {
      for (const headers of [{}, { origin: "http://evil.example" }]) {
        const r = await raw("GET", to, headers);
        expect(r.status).toBe(200);
        expect(r.headers["access-control-allow-origin"]).toBeUndefined();
      }
    }
    const pre = await raw("OPTIONS", `${path}/actions/jog`, { origin: "http://evil.example", "access-control-request-method": "POST" });
    expect(pre.status).toBe(403);
    expect(pre.headers["access-control-allow-origin"]).toBeUndefined();
    const ok = await raw("OPTIONS", `${path}/actions/jog`, { origin: DASHBOARD, "access-control-request-method": "POST" });
    expect(ok.status).toBe(204);
    expect(ok.headers["access-control-allow-origin"]).toBe(DASHBOARD);
  });

  it("takes no command in a 'simple' request: a text/plain jog answers 415 and the robot does not move", async () => {
    const r = await stillAfter(() => raw("POST", `${path}/actions/jog`, { "content-type": "text/plain" }, JOG));
    expect(r.status).toBe(415);
    expect(r.body.code).toBe("E_UNSUPPORTED_MEDIA_TYPE");
  });
});

const DEEP = `${"[".repeat(40)}${"]".repeat(40)}`;
describe("bad input", () => {
  it.each([
    ["a jog of an unknown joint", "jog", { velocities: { elbow: 0.5 }, duration: 0.2 }, "E_BAD_INPUT", /unknown property 'elbow'/],
    ["a jog velocity that is a string", "jog", { velocities: { [J1]: "fast" }, duration: 0.2 }, "E_BAD_INPUT", /must be number/],
    ["a jog velocity of 1e999 (Infinity)", "jog", `{"velocities": {"${J1}": 1e999}, "duration": 0.2}`, "E_BAD_INPUT", /must be finite/],
    ["a jog without its duration", "jog", { velocities: { [J1]: 0.5 } }, "E_BAD_INPUT", /missing required property 'duration'/],
    ["a jog of 61 s", "jog", { velocities: { [J1]: 0.5 }, duration: 61 }, "E_BAD_INPUT", /duration must be <= 60/],
    ["a jog with an extra field", "jog", { velocities: { [J1]: 0.5 }, duration: 0.2, force: 1 }, "E_BAD_INPUT", /unknown property 'force'/],
    ["a joint move missing a joint", "moveToJointPosition", { joints: { [J1]: 0.1 } }, "E_BAD_INPUT", /missing required property/],
    ["a joint move beyond a limit", "moveToJointPosition", { joints: kukaPose([4, 0, 0, 0, 0, 0, 0]) }, "E_BAD_INPUT", /lbr_iiwa_joint_1 must be <=/],
    ["a joint move at speed 0", "moveToJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]), speed: 0 }, "E_BAD_INPUT", /speed must be >=/],
    ["a Cartesian move with x a string", "moveToCartesianPosition", { x: "0.5", y: 0, z: 0.5 }, "E_BAD_INPUT", /\/x must be number/],
    ["an array instead of an object", "jog", [1, 2], "E_BAD_INPUT", /must be object/],
    ["malformed JSON", "jog", "{velocities:", "E_BAD_JSON", /not valid JSON/],
    ["an empty body", "jog", "", "E_MISSING_BODY", /needs a JSON body/],
    ["JSON nested 40 deep", "jog", DEEP, "E_TOO_DEEP", /nests 40 levels/],
  ])("%s answers 400 problem details and the robot does not move", async (_what, action, body, code, detail) => {
    const text = typeof body === "string" ? body : JSON.stringify(body);
    const r = await stillAfter(() => raw("POST", `${path}/actions/${action}`, { "content-type": "application/json" }, text));
    expect(r.status, JSON.stringify(r.body)).toBe(400);
    expect(r.headers["content-type"]).toBe(PROBLEM);
    expect(r.body).toMatchObject({ status: 400, code });
    expect(r.body.detail).toMatch(detail);
  });

  it("a command while it moves answers 409 E_BUSY, an unreachable target 422, both as problem details", async () => {
    const long = invoke(robot.tdUrl, "jog", { velocities: { [J1]: -0.2 }, duration: 20 });
    await waitState(robot.tdUrl, "moving");
    const busy = await invoke(robot.tdUrl, "moveToJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) });
    expect(busy.status).toBe(409);
    expect(busy.type).toBe(PROBLEM);
    expect(busy.body.code).toBe("E_BUSY");
    expect((await invoke(robot.tdUrl, "stop", "")).body).toEqual({ stopped: true });
    expect((await long).body.status).toBe("stopped");
    // inside the twin's Cartesian bounds, beyond the arm's reach
    const far = await invoke(robot.tdUrl, "moveToCartesianPosition", { x: 0.9, y: 0.9, z: 1.2 });
    expect(far.status, JSON.stringify(far.body)).toBe(422);
    expect(far.type).toBe(PROBLEM);
    expect(far.body.code).toBe("E_UNREACHABLE");
  });

  it("only its own routes reach node-wot: its id route and unknown paths 404, a wrong method 405", async () => {
    const td = (await http(robot.tdUrl)).body;
    expect(td.id).toMatch(/:emulated$/);
    // node-wot also serves the Thing at /<url-encoded id>: past every check above
    const byId = await raw("POST", `/${encodeURIComponent(td.id)}/actions/jog`, { "content-type": "application/json" }, JOG);
    expect(byId.status).toBe(404);
    expect(byId.headers["content-type"]).toBe(PROBLEM);
    expect((await raw("GET", "/", {})).status).toBe(404);
    expect((await raw("GET", `${path}/actions/nope`, {})).status).toBe(404);
    const get = await raw("GET", `${path}/actions/jog`, {});
    expect(get.status).toBe(405);
    expect(get.headers.allow).toBe("POST");
    // the served TD names only the routes let through, in JSON
    const hrefs = [...Object.values(td.properties), ...Object.values(td.actions)].flatMap((a: any) => a.forms.map((f: any) => f.href as string));
    expect(hrefs.length).toBeGreaterThan(0);
    for (const h of hrefs) expect(new URL(h).pathname.startsWith(`${path}/`)).toBe(true);
    expect(new Set([...Object.values(td.actions)].flatMap((a: any) => a.forms.map((f: any) => f.contentType)))).toEqual(new Set(["application/json"]));
  });
});

describe("request bodies", () => {
  it("a streamed body 64 MiB long answers 413 at the servient's cap, is not read on and not buffered", async () => {
    const total = 64 * 1024 * 1024;
    const chunk = new Uint8Array(64 * 1024).fill(0x20);
    let pulled = 0;
    const body = new ReadableStream<Uint8Array>({
      pull(c) {
        if (pulled >= total) return c.close();
        pulled += chunk.length;
        c.enqueue(chunk);
      },
    });
    const rss = process.memoryUsage().rss;
    const r = await fetch(`${robot.tdUrl}/actions/jog`, { method: "POST", headers: { "content-type": "application/json" }, body, duplex: "half" } as RequestInit);
    const problem = (await r.json()) as { code: string; details: { limit: number } };
    expect(r.status).toBe(413);
    expect(r.headers.get("content-type")).toBe(PROBLEM);
    expect(problem.code).toBe("E_TOO_LARGE");
    expect(problem.details.limit).toBe(MAX_BODY);
    // cut at the cap: the client was not asked for the rest (socket buffers hold a few MB at most)
    expect(pulled).toBeLessThan(MAX_BODY + 16 * 1024 * 1024);
    expect(process.memoryUsage().rss - rss).toBeLessThan(50 * 1024 * 1024);
    // and it serves on
    expect((await invoke(robot.tdUrl, "stop", "")).status).toBe(200);
  });

  it("a body just under the cap is read and judged by its content (400, not 413)", async () => {
    const head = `{"velocities": {}, "duration": 0.1, "pad": "`;
    const r = await invoke(robot.tdUrl, "jog", `${head}${"x".repeat(MAX_BODY - head.length - 2)}"}`);
    expect(r.status).toBe(400);
    expect(r.body.detail).toMatch(/unknown property 'pad'/);
  });
});

describe("binding a non-loopback address", () => {
  /** The warnings `startEmulator` emits on `host`; the bind itself fails (the address is not this machine's). */
  async function warningsOn(host: string, auth?: { scheme: "bearer"; token: string }): Promise<{ code?: string; message: string }[]> {
    const seen: { code?: string; message: string }[] = [];
    const listener = (w: Error & { code?: string }): void => void seen.push({ code: w.code, message: w.message });
    process.on("warning", listener);
    try {
      await expect(startEmulator({ folder: dir, port: 0, host, ...(auth ? { auth } : {}) })).rejects.toThrow(/robwot emulate/);
      // a warning is delivered on process.nextTick: a tick queued now runs after every one emitted before
      await new Promise<void>((r) => process.nextTick(r));
    } finally {
      process.off("warning", listener);
    }
    return seen;
  }

  it("without --auth warns ROBWOT_NO_AUTH, with --auth it does not", async () => {
    const warned = await warningsOn(NOT_LOOPBACK);
    expect(warned).toContainEqual({ code: "ROBWOT_NO_AUTH", message: `robwot emulate: binding ${NOT_LOOPBACK} without --auth exposes the robot to the network` });
    expect((await warningsOn(NOT_LOOPBACK, { scheme: "bearer", token: "t" })).filter((w) => w.code === "ROBWOT_NO_AUTH")).toEqual([]);
  });

  it("the CLI says so in its own words, once; with --auth it does not", async () => {
    const r = await runCli(["emulate", dir, "--host", NOT_LOOPBACK, "--port", "0"], { timeoutMs: 60_000 });
    expect(r.code).not.toBe(0);
    expect(r.stderr).toContain(`robwot: warning: binding ${NOT_LOOPBACK} without --auth: anyone on the network can move the robot`);
    expect(r.stderr.match(/without --auth/g)).toHaveLength(1);
    expect(r.stderr).not.toMatch(/\(node:\d+\) Warning/);
    const secured = await runCli(["emulate", dir, "--host", NOT_LOOPBACK, "--port", "0", "--auth", "bearer:t"], { timeoutMs: 60_000 });
    expect(secured.code).not.toBe(0);
    expect(secured.stderr).not.toMatch(/without --auth/);
  });
});
