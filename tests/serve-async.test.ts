/**
 * Asynchronous move actions (W3C WoT Profile, HTTP Basic Profile): `Prefer: respond-async` answers 201
 * with `Location` and an ActionStatus; GET on it (queryaction) follows pending -> running (progress) ->
 * completed with the result; DELETE (cancelaction) stops the move like `stop` and deletes its status (204,
 * then 404), a DELETE after the end cancels nothing (409). Without the preference the
 * invocation stays synchronous. Real servient, real backend, real HTTP (fetch); the TD's forms are used.
 */
import AjvModule from "ajv";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { ServerRequests } from "./helpers/server-requests.js";
import { consumer, generateTwin, http, invoke, kukaPose, waitFor, type HttpAnswer } from "./serve-helpers.js";

const HOME = kukaPose([0, 0, 0, 0, 0, 0, 0]);
const FAR = kukaPose([1.5, 0.4, 0, -1.0, 0, 0.5, 0]);
const ASYNC = { prefer: "respond-async" };
const DASH = "https://dash.example";
const ISO = /^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}\.\d{3}Z$/;
const Ajv = AjvModule.default;
/** Every ActionStatus and error body is checked against the schema the served TD declares for it. */
let conforms: { status(body: unknown): void; error(body: unknown): void };

function schemasOf(td: any): typeof conforms {
  const ajv = new Ajv({ strict: false, validateFormats: false });
  const status = ajv.compile(td.schemaDefinitions.actionStatus);
  const error = ajv.compile(td.schemaDefinitions.error);
  return {
    status: (b) => expect(status(b), `${JSON.stringify(b)}: ${ajv.errorsText(status.errors)}`).toBe(true),
    error: (b) => expect(error(b), JSON.stringify(b)).toBe(true),
  };
}

async function answer(r: Response): Promise<HttpAnswer & { headers: Headers }> {
  const text = await r.text();
  const body = text ? JSON.parse(text) : null;
  if (body !== null && (r.status === 201 || r.url.match(/\/actions\/move\w+\/[^/]+$/))) {
    if (r.status < 300) conforms.status(body);
    else conforms.error(body);
  }
  return { status: r.status, type: r.headers.get("content-type"), body, headers: r.headers };
}

async function invokeAsync(base: string, action: string, body: unknown, headers: Record<string, string> = {}) {
  return answer(await fetch(`${base}/actions/${action}`, { method: "POST", headers: { "content-type": "application/json", ...ASYNC, ...headers }, body: JSON.stringify(body) }));
}

const query = async (href: string, headers: Record<string, string> = {}) => answer(await fetch(href, { headers }));
const cancel = async (href: string, headers: Record<string, string> = {}) => answer(await fetch(href, { method: "DELETE", headers }));

/** Polls the ActionStatus until it has ended; returns every status seen. */
async function poll(href: string, headers: Record<string, string> = {}): Promise<any[]> {
  const seen: any[] = [];
  const ended = async (): Promise<boolean> => {
    const r = await query(href, headers);
    expect(r.status).toBe(200);
    seen.push(r.body);
    return !["pending", "running"].includes(r.body.status);
  };
  await waitFor(ended, { intervalMs: 40, what: `the end of ${href}` });
  return seen;
}

describe("asynchronous moves", () => {
  let s: RunningServient;
  let base: string;
  let td: any;
  const joints = async (): Promise<Record<string, number>> => (await http(`${base}/properties/getJointPosition`)).body;

  beforeAll(async () => {
    s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1, corsOrigins: [DASH] });
    base = `${s.url}/${s.things[0]!.slug}`;
    td = (await http(base)).body;
    conforms = schemasOf(td);
  });
  afterAll(async () => s?.stop());

  it("Prefer: respond-async -> 201, Location, ActionStatus; polled through running (progress) to completed with the result", async () => {
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
    // the TD's asynchronous form states the header and the answer
    const form = td.actions.moveToJointPosition.forms.find((f: any) => f["htv:headers"]);
    expect(form["htv:headers"]).toEqual([{ "htv:fieldName": "Prefer", "htv:fieldValue": "respond-async" }]);
    const r = await answer(await fetch(form.href, { method: "POST", headers: { "content-type": "application/json", prefer: "respond-async" }, body: JSON.stringify({ joints: FAR, speed: 0.5 }) }));
    expect(r.status).toBe(201);
    expect(r.type).toMatch(/^application\/json/);
    expect(r.headers.get("preference-applied")).toBe("respond-async");
    const href = r.headers.get("location")!;
    expect(r.body.href).toBe(href);
    // the queryaction form's template names the same resource
    const qform = td.actions.moveToJointPosition.forms.find((f: any) => f.op.includes("queryaction"));
    expect(href).toBe(qform.href.replace("{actionID}", href.split("/").pop()));
    expect(["pending", "running"]).toContain(r.body.status);
    expect(r.body.timeRequested).toMatch(ISO);
    expect(r.body.timeEnded).toBeUndefined();
    const seen = await poll(href);
    const progress = seen.filter((x) => x.status === "running").map((x) => x.progress as number);
    expect(progress.some((p) => p > 0 && p < 1)).toBe(true);
    for (let i = 1; i < progress.length; i++) expect(progress[i]).toBeGreaterThanOrEqual(progress[i - 1]!);
    const done = seen.at(-1);
    expect(done).toMatchObject({ status: "completed", progress: 1, href, timeRequested: r.body.timeRequested });
    expect(done.timeEnded >= done.timeRequested).toBe(true);
    expect(done.output.status).toBe("reached");
    for (const [name, v] of Object.entries(FAR)) expect(done.output.joints[name]).toBeCloseTo(v, 6);
    expect(await joints()).toEqual(done.output.joints);
    // the status stays queryable after the end
    expect((await query(href)).body).toEqual(done);
  });

  it("a node-wot consumer chooses from the TD: the first form is synchronous, formIndex 1 (the Prefer form) asynchronous", async () => {
    const c = await consumer();
    try {
      const thing = await c.wot.consume(td);
      const sync = await (await thing.invokeAction("moveToJointPosition", { joints: HOME })).value();
      expect(sync).toMatchObject({ status: "reached" });
      // node-wot 0.9.2 sends the form's htv:headers and answers the 201's body: the ActionStatus; the action
      // is synchronous (its plain POST answers the result), so value() would check the status against the
      // output schema and throw: the body is read as bytes
      const out = await thing.invokeAction("moveToJointPosition", { joints: FAR, speed: 0.5 }, { formIndex: 1 });
      const st = JSON.parse(Buffer.from(await out.arrayBuffer()).toString("utf8"));
      expect(["pending", "running"]).toContain(st.status);
      expect(st.href).toMatch(/\/actions\/moveToJointPosition\/[0-9a-f-]{36}$/);
      expect((await poll(st.href)).at(-1)).toMatchObject({ status: "completed", output: { status: "reached" } });
    } finally {
      await c.stop();
    }
  });

  it("a Cartesian move answers asynchronously too, with the synchronous result as output", async () => {
    const p = (await http(`${base}/properties/getCartesianPosition`)).body;
    const target = { x: p.x - 0.05, y: p.y, z: p.z - 0.05 };
    const r = await invokeAsync(base, "moveToCartesianPosition", { ...target, speed: 0.5 });
    expect(r.status).toBe(201);
    const done = (await poll(r.headers.get("location")!)).at(-1);
    expect(done.status).toBe("completed");
    expect(done.output.status).toBe("reached");
    expect(done.output.positionError).toBeLessThan(0.01);
  });

  it("DELETE mid-move cancels it (the stop path): 204, the status deleted (404 naming the cancel), the robot no longer moves", async () => {
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
    const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.2 });
    expect(r.status).toBe(201);
    const href = r.headers.get("location")!;
    await waitFor(
      async () => {
        const st = (await query(href)).body;
        if (!["pending", "running"].includes(st.status)) throw new Error(`not running: ${JSON.stringify(st)}`);
        return st.status === "running" && st.progress > 0.1;
      },
      { what: "the move running past 10 %" },
    );
    const del = await cancel(href);
    expect(del.status).toBe(204);
    expect(del.body).toBeNull();
    expect(del.type).toBeNull();
    // the Profile: a cancelled invocation's ActionStatus is deleted
    const gone = await query(href);
    expect(gone.status).toBe(404);
    expect(gone.type).toBe("application/problem+json");
    expect(gone.body.detail).toMatch(/was cancelled at/);
    const a = await joints();
    expect(a.lbr_iiwa_joint_1).toBeGreaterThan(0.01);
    expect(a.lbr_iiwa_joint_1).toBeLessThan(1.49);
    // the DELETE answers once the move has ended (the backend answered its motion, after every state of
    // it): a later backend call (a validation) finds the twin where it stopped
    expect((await invoke(base, "validateJointPosition", { joints: HOME })).status).toBe(200);
    expect(await joints()).toEqual(a);
    expect((await http(`${base}/properties/motionStatus`)).body.state).toBe("stopped");
    // a second DELETE: nothing left to cancel
    expect((await cancel(href)).status).toBe(404);
    // the twin takes the next move at once
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
  });

  it("a DELETE after the move ended cancels nothing: 409 problem details, the completed status stays", async () => {
    const r = await invokeAsync(base, "moveToJointPosition", { joints: HOME, speed: 0.5 });
    expect(r.status).toBe(201);
    const href = r.headers.get("location")!;
    const done = (await poll(href)).at(-1);
    expect(done.status).toBe("completed");
    const del = await cancel(href);
    expect(del.status).toBe(409);
    expect(del.type).toBe("application/problem+json");
    expect(del.body).toMatchObject({ status: 409, code: "E_NOT_CANCELLABLE", details: { status: "completed" } });
    expect((await query(href)).body).toEqual(done);
  });

  it("a move cancelled while pending never starts (backend frozen until the cancel is in)", async () => {
    const before = await joints();
    const pid = s.backend.pid!;
    process.kill(pid, "SIGSTOP");
    let del: Promise<HttpAnswer & { headers: Headers }>;
    let href: string;
    const requests = new ServerRequests();
    try {
      const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.2 });
      expect(r.status).toBe(201);
      expect(r.body).toMatchObject({ status: "pending", progress: 0 });
      href = r.headers.get("location")!;
      expect((await query(href)).body).toMatchObject({ status: "pending", progress: 0 });
      del = cancel(href);
      // the servient has taken the DELETE (the move is cancelled; its answer waits for the move's end)
      await requests.next((req) => req.method === "DELETE", "the DELETE");
    } finally {
      requests.close();
      process.kill(pid, "SIGCONT");
    }
    // the DELETE answers once the move has ended: it never started
    expect((await del).status).toBe(204);
    expect((await query(href)).status).toBe(404);
    expect(await joints()).toEqual(before);
  });

  it("without the preference the invocation is synchronous; a preference a sync action cannot honour is ignored", async () => {
    const r = await answer(await fetch(`${base}/actions/moveToJointPosition`, { method: "POST", headers: { "content-type": "application/json" }, body: JSON.stringify({ joints: HOME }) }));
    expect(r.status).toBe(200);
    expect(r.headers.get("location")).toBeNull();
    expect(r.body.status).toBe("reached");
    const v = await invokeAsync(base, "validateJointPosition", { joints: HOME });
    expect(v.status).toBe(200);
    expect(v.headers.get("preference-applied")).toBeNull();
    expect(v.body.valid).toBe(true);
  });

  it("errors before acceptance are the invocation's answer: 400 input, 409 busy; nothing is created", async () => {
    const bad = await invokeAsync(base, "moveToJointPosition", { joints: { ...HOME, nope: 1 } });
    expect(bad.status).toBe(400);
    expect(bad.headers.get("location")).toBeNull();
    const first = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.3 });
    expect(first.status).toBe(201);
    const busy = await invokeAsync(base, "moveToJointPosition", { joints: HOME });
    expect(busy.status).toBe(409);
    expect(busy.body.code).toBe("E_BUSY");
    expect(busy.headers.get("location")).toBeNull();
    expect((await cancel(first.headers.get("location")!)).status).toBe(204);
  });

  it("a target the validation refuses: the status fails with the synchronous error (422 E_REJECTED)", async () => {
    expect((await invoke(base, "moveToJointPosition", { joints: FAR })).body.status).toBe("reached");
    const tcp = (await http(`${base}/properties/getCartesianPosition`)).body;
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
    // the target itself touches an obstacle
    expect((await invoke(base, "addObstacle", { name: "ball", shape: { type: "sphere", radius: 0.05 }, position: [tcp.x, tcp.y, tcp.z] })).status).toBe(200);
    try {
      const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR });
      expect(r.status).toBe(201);
      const done = (await poll(r.headers.get("location")!)).at(-1);
      expect(done.status).toBe("failed");
      expect(done.error).toMatchObject({ type: "https://robwot.dev/errors#E_REJECTED", code: "E_REJECTED", status: 422 });
      expect(done.error.detail).toBe(done.error.message);
      expect(done.error.details.checks.path.ok).toBe(false);
      expect(done.output).toBeUndefined();
      expect(done.timeEnded).toMatch(ISO);
    } finally {
      expect((await invoke(base, "removeObstacle", { name: "ball" })).status).toBe(200);
    }
  });

  it("browsers: a page of another origin may not cancel (403); a --cors-origin dashboard may, and reads Location", async () => {
    const pre = await fetch(`${base}/actions/moveToJointPosition/x`, {
      method: "OPTIONS",
      headers: { origin: DASH, "access-control-request-method": "DELETE", "access-control-request-headers": "prefer" },
    });
    expect(pre.status).toBe(204);
    expect(pre.headers.get("access-control-allow-methods")).toContain("DELETE");
    expect(pre.headers.get("access-control-allow-headers")).toContain("prefer");
    expect((await invoke(base, "moveToJointPosition", { joints: HOME })).body.status).toBe("reached");
    const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.3 }, { origin: DASH });
    expect(r.status).toBe(201);
    expect(r.headers.get("access-control-expose-headers")).toContain("Location");
    const href = r.headers.get("location")!;
    const evil = await cancel(href, { origin: "http://evil.example" });
    expect(evil.status).toBe(403);
    expect(evil.body.code).toBe("E_FORBIDDEN_ORIGIN");
    expect(["pending", "running"]).toContain((await query(href)).body.status);
    expect((await cancel(href, { origin: DASH })).status).toBe(204);
    expect((await query(href)).status).toBe(404);
  });

  it("unknown ids answer 404, sync-only actions have no status resources, other methods 405", async () => {
    const unknown = `${base}/actions/moveToJointPosition/00000000-0000-0000-0000-000000000000`;
    expect((await query(unknown)).status).toBe(404);
    expect((await query(unknown)).body.code).toBe("E_NOT_FOUND");
    expect((await cancel(unknown)).status).toBe(404);
    // an id of one action is not a resource of the other
    const r = await invokeAsync(base, "moveToJointPosition", { joints: HOME });
    const id = r.headers.get("location")!.split("/").pop();
    await poll(r.headers.get("location")!);
    expect((await query(`${base}/actions/moveToCartesianPosition/${id}`)).status).toBe(404);
    expect((await query(`${base}/actions/validateJointPosition/${id}`)).status).toBe(404);
    const post = await answer(await fetch(r.headers.get("location")!, { method: "POST" }));
    expect(post.status).toBe(405);
    expect(post.headers.get("allow")).toBe("GET, DELETE");
  });
});

describe("asynchronous moves and a backend that dies", () => {
  let s: RunningServient;
  let base: string;

  beforeAll(async () => {
    s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1 });
    base = `${s.url}/${s.things[0]!.slug}`;
    conforms = schemasOf((await http(base)).body);
  });
  afterAll(async () => s?.stop());

  it("killed mid-move: the status fails with the synchronous error (503 E_BACKEND_DOWN); after the restart the next one completes", async () => {
    const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.1 });
    expect(r.status).toBe(201);
    const href = r.headers.get("location")!;
    await waitFor(async () => (await query(href)).body.status === "running", { what: "the move running" });
    const pid = s.backend.pid!;
    process.kill(pid, "SIGKILL");
    const done = (await poll(href)).at(-1);
    expect(done.status).toBe("failed");
    expect(done.error).toMatchObject({ code: "E_BACKEND_DOWN", status: 503 });
    expect(done.progress).toBeGreaterThan(0);
    expect(done.progress).toBeLessThan(1);
    // nothing left to cancel: 409, the failure stays
    expect((await cancel(href)).status).toBe(409);
    expect((await query(href)).body).toEqual(done);
    // while the backend is down, the invocation itself is refused (no status resource)
    const during = await invokeAsync(base, "moveToJointPosition", { joints: HOME });
    if (during.status !== 201) {
      expect(during.status).toBe(503);
      expect(during.headers.get("location")).toBeNull();
    } else await poll(during.headers.get("location")!);
    await s.backend.waitUp(60_000);
    expect(s.backend.pid).not.toBe(pid);
    const again = await invokeAsync(base, "moveToJointPosition", { joints: HOME });
    expect(again.status).toBe(201);
    expect((await poll(again.headers.get("location")!)).at(-1)).toMatchObject({ status: "completed", output: { status: "reached" } });
  });
});

describe("asynchronous moves with auth", () => {
  let s: RunningServient;
  let base: string;
  const good = { authorization: `Basic ${Buffer.from("ada:s3cret").toString("base64")}` };
  const bad = { authorization: `Basic ${Buffer.from("ada:wrong").toString("base64")}` };

  beforeAll(async () => {
    s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1, auth: { scheme: "basic", user: "ada", password: "s3cret" } });
    base = `${s.url}/${s.things[0]!.slug}`;
    conforms = schemasOf((await http(base, { headers: good })).body);
  });
  afterAll(async () => s?.stop());

  it("the invocation, the query and the cancel need the credentials", async () => {
    expect((await invokeAsync(base, "moveToJointPosition", { joints: FAR })).status).toBe(401);
    expect((await invokeAsync(base, "moveToJointPosition", { joints: FAR }, bad)).status).toBe(401);
    expect(s.twins.values().next().value!.busy).toBe(false);
    const r = await invokeAsync(base, "moveToJointPosition", { joints: FAR, speed: 0.3 }, good);
    expect(r.status).toBe(201);
    const href = r.headers.get("location")!;
    for (const h of [{}, bad]) {
      expect((await query(href, h)).status).toBe(401);
      expect((await cancel(href, h)).status).toBe(401);
    }
    // the refused cancels did not stop it
    const done = (await poll(href, good)).at(-1);
    expect(done.status).toBe("completed");
    expect(done.output.status).toBe("reached");
    expect((await cancel(href, good)).status).toBe(409);
    expect((await query(href, good)).body.status).toBe("completed");
  });
});
