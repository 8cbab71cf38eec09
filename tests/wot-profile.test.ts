/**
 * The served twin against the W3C WoT Profile (Editor's Draft, github.com/w3c/wot-profile index.html):
 * the HTTP Basic Profile (properties, actions, ActionStatus, errors, security) and the HTTP SSE Profile
 * (observeproperty, subscribeevent), one `it` per rule, named after the Profile's section and wording.
 * Everything goes over real HTTP to `robwot`'s servient with `--auth basic`, forms taken from the served TD
 * the way the Profile tells a Consumer to find them (op, http(s) href, contentType, subprotocol).
 */
import AjvModule from "ajv";
import addFormats from "ajv-formats";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { openSse } from "./helpers/sse.js";
import { generateTwin, kukaPose, waitFor, waitState } from "./serve-helpers.js";

const BASIC = "https://www.w3.org/2022/wot/profile/http-basic/v1";
const SSE = "https://www.w3.org/2022/wot/profile/http-sse/v1";
const TD11 = "https://www.w3.org/2022/wot/td/v1.1";
/** RFC 3339 date-time (Profile "Date Format") */
const RFC3339 = /^\d{4}-\d{2}-\d{2}T([01]\d|2[0-3]):[0-5]\d:[0-5]\d(\.\d+)?(Z|[+-]([01]\d|2[0-3]):[0-5]\d)$/;
const STATUSES = ["pending", "running", "completed", "failed"];
const HOME = kukaPose([0, 0, 0, 0, 0, 0, 0]);
const FAR = kukaPose([1.5, 0.4, 0, -1.0, 0, 0.5, 0]);
const AUTH = { authorization: `Basic ${Buffer.from("ada:s3cret").toString("base64")}` };
const Ajv = AjvModule.default;

type Form = { href: string; op?: string | string[]; contentType?: string; subprotocol?: string; "htv:methodName"?: string; "htv:headers"?: unknown };
let s: RunningServient;
let td: any;
const ajv = new Ajv({ strict: false, allErrors: true });
addFormats.default(ajv);

interface Answer {
  status: number;
  type: string | null;
  headers: Headers;
  text: string;
  body: any;
}

async function request(url: string, init: RequestInit = {}, auth = true): Promise<Answer> {
  const r = await fetch(url, { ...init, headers: { ...(auth ? AUTH : {}), ...(init.headers as Record<string, string>) } });
  const text = await r.text();
  let body: unknown = undefined;
  try {
    body = JSON.parse(text);
  } catch {
    /* not JSON: the assertions say so */
  }
  return { status: r.status, type: r.headers.get("content-type"), headers: r.headers, text, body };
}

const ops = (f: Form): string[] => (Array.isArray(f.op) ? f.op : f.op ? [f.op] : []);
const isHttp = (f: Form): boolean => /^https?:$/.test(new URL(f.href, td.base).protocol);
/** The form a Profile Consumer uses for `op`: http(s) href, contentType application/json, the subprotocol if any. */
function formFor(forms: Form[], op: string, subprotocol?: string): Form {
  const f = forms.find((x) => ops(x).includes(op) && isHttp(x) && (x.contentType ?? "application/json") === "application/json" && x.subprotocol === subprotocol && !x["htv:headers"]);
  if (!f) throw new Error(`no ${op} form${subprotocol ? ` (${subprotocol})` : ""} in ${JSON.stringify(forms)}`);
  return f;
}

function conforms(schema: object, value: unknown, what: string): void {
  const validate = ajv.compile(schema);
  expect(validate(value), `${what}: ${JSON.stringify(value).slice(0, 300)}: ${ajv.errorsText(validate.errors)}`).toBe(true);
}

/** Profile "Errors": an error answer with a body is RFC 7807 problem details. */
function isProblem(a: Answer, status: number): void {
  expect(a.status).toBe(status);
  expect(a.type).toBe("application/problem+json");
  expect(a.body).toMatchObject({ type: expect.any(String), title: expect.any(String), status, detail: expect.any(String) });
  expect(() => new URL(a.body.type)).not.toThrow();
}

function invoke(name: string, input: unknown, headers: Record<string, string> = {}): Promise<Answer> {
  const form = formFor(td.actions[name].forms, "invokeaction");
  return request(new URL(form.href, td.base).href, {
    method: "POST",
    headers: { accept: "application/json", "content-type": "application/json", ...headers },
    body: JSON.stringify(input),
  });
}

/** The asynchronous invocation (the Prefer form, beyond the Profile's plain POST) and its status resource. */
async function invokeAsync(name: string, input: unknown): Promise<Answer> {
  const form = (td.actions[name].forms as Form[]).find((f) => f["htv:headers"])!;
  return request(form.href, { method: "POST", headers: { accept: "application/json", "content-type": "application/json", prefer: "respond-async" }, body: JSON.stringify(input) });
}

async function pollEnd(href: string): Promise<any> {
  return waitFor(
    async () => {
      const a = await request(href, { headers: { accept: "application/json" } });
      expect(a.status).toBe(200);
      return !["pending", "running"].includes(a.body.status) && a.body;
    },
    { intervalMs: 40, what: `the end of ${href}` },
  );
}

/** The twin's joints as the Profile Consumer reads them. */
const joints = async (): Promise<Record<string, number>> => (await request(new URL("properties/getJointPosition", td.base).href)).body;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 1, auth: { scheme: "basic", user: "ada", password: "s3cret" } });
  td = (await request(s.things[0]!.tdUrl)).body;
}, 300_000);
afterAll(async () => s?.stop());

describe("Profiling Mechanism and Identifiers", () => {
  it("the TD has a profile member with the HTTP Basic Profile's identifier", () => {
    expect([td.profile].flat()).toContain(BASIC);
  });
  it("the TD has a profile member with the HTTP SSE Profile's identifier", () => {
    expect([td.profile].flat()).toContain(SSE);
  });
  it("the value of profile is a valid URI or an array of valid URIs", () => {
    for (const uri of [td.profile].flat()) expect(() => new URL(uri)).not.toThrow();
  });
  it("a TD with a profile member has https://www.w3.org/2022/wot/td/v1.1 in its @context", () => {
    expect([td["@context"]].flat()).toContain(TD11);
  });
});

describe("Common Constraints", () => {
  it("Discovery: the TD is retrievable from an HTTP URL", async () => {
    const a = await request(s.things[0]!.tdUrl);
    expect(a.status).toBe(200);
    expect(a.type).toContain("application/td+json");
    expect(a.body.id).toBe(td.id);
  });
  it("Security: the Thing uses NoSecurityScheme, BasicSecurityScheme or OAuth2 (code or client flow)", () => {
    for (const name of [td.security].flat()) {
      const scheme = td.securityDefinitions[name];
      expect(["nosec", "basic", "oauth2"]).toContain(scheme.scheme);
      if (scheme.scheme === "oauth2") expect(["code", "client"]).toContain(scheme.flow);
    }
  });
  it('Security: the BasicSecurityScheme\'s "in" is omitted or "header"', () => {
    const basic = Object.values(td.securityDefinitions as Record<string, any>).filter((d) => d.scheme === "basic");
    expect(basic.length).toBeGreaterThan(0);
    for (const d of basic) expect([undefined, "header"]).toContain(d.in);
  });
  it('Security: the BasicSecurityScheme\'s "name" is "Authorization" (no proxy is given)', () => {
    for (const d of Object.values(td.securityDefinitions as Record<string, any>).filter((x) => x.scheme === "basic")) {
      expect(d.proxy).toBeUndefined();
      expect(d.name).toBe("Authorization");
    }
  });
  it("Security: a Thing whose TD needs authentication implements security bootstrapping (Discovery: 401 with WWW-Authenticate)", async () => {
    const a = await request(s.things[0]!.tdUrl, {}, false);
    expect(a.status).toBe(401);
    expect(a.headers.get("www-authenticate")).toMatch(/^Basic realm=/);
    expect((await request(s.things[0]!.tdUrl)).status).toBe(200);
  });
  it("Errors: a failed operation answers an HTTP error code; a body is Problem Details (RFC 7807)", async () => {
    const read = formFor(td.properties.getJointPosition.forms, "readproperty");
    // 401 without credentials
    isProblem(await request(read.href, { headers: { accept: "application/json" } }, false), 401);
    // 404: an affordance the Thing does not have
    isProblem(await request(new URL("properties/nope", td.base).href), 404);
    // 400: an input its schema refuses
    isProblem(await invoke("validateJointPosition", { joints: { nope: 1 } }), 400);
    // 405: a method the resource does not serve
    isProblem(await request(read.href, { method: "DELETE" }), 405);
    // 415: an input that is not JSON
    const inv = formFor(td.actions.stop.forms, "invokeaction");
    isProblem(await request(inv.href, { method: "POST", headers: { "content-type": "text/plain" }, body: "x" }), 415);
  });
  it("Errors: a Web Thing MUST NOT respond 300 Multiple Choices", async () => {
    for (const url of [s.things[0]!.tdUrl, new URL("properties", td.base).href, `${s.url}/viewer`]) {
      expect((await request(url, { redirect: "manual" })).status).not.toBe(300);
    }
  });
});

describe("HTTP Basic Profile: Properties", () => {
  it("readproperty: GET with Accept application/json answers 200, Content-Type application/json, the value in JSON per its schema", async () => {
    for (const [name, p] of Object.entries(td.properties as Record<string, any>)) {
      const form = formFor(p.forms, "readproperty");
      const a = await request(form.href, { headers: { accept: "application/json" } });
      expect(a.status, name).toBe(200);
      expect(a.type, name).toMatch(/^application\/json/);
      const { forms: _f, observable: _o, ...schema } = p;
      conforms(schema, a.body, name);
    }
  });
  it("readallproperties: the top-level form answers 200 with the values of every readable property, keyed by name", async () => {
    const form = formFor(td.forms, "readallproperties");
    const a = await request(new URL(form.href, td.base).href, { headers: { accept: "application/json" } });
    expect(a.status).toBe(200);
    expect(a.type).toMatch(/^application\/json/);
    expect(Object.keys(a.body).sort()).toEqual(Object.keys(td.properties).sort());
  });
});

describe("HTTP Basic Profile: Actions", () => {
  it("invokeaction: the synchronous member of every ActionAffordance is set to true or false", () => {
    for (const [name, a] of Object.entries(td.actions as Record<string, any>)) expect(typeof a.synchronous, name).toBe("boolean");
  });

  it("Synchronous Action Response: an action with an output answers 200, Content-Type application/json, the output per its schema", async () => {
    const cases: [string, unknown][] = [
      ["moveToJointPosition", { joints: HOME, speed: 0.5 }],
      ["validateJointPosition", { joints: FAR }],
      ["validateCartesianPosition", { x: 0.4, y: 0, z: 0.6 }],
      ["addObstacle", { name: "profile-box", shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [1.5, 1.5, 0.1] }],
      ["moveObstacle", { name: "profile-box", position: [1.5, -1.5, 0.1] }],
      ["removeObstacle", { name: "profile-box" }],
      ["addObject", { name: "profile-cube", shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [1.5, 1.5, 0.3] }],
      ["moveObject", { name: "profile-cube", position: [1.5, -1.5, 0.3] }],
      ["removeObject", { name: "profile-cube" }],
      ["stop", {}],
    ];
    for (const [name, input] of cases) {
      const action = td.actions[name];
      expect(action.synchronous, name).toBe(true);
      expect(action.output, `${name} has an output`).toBeDefined();
      const a = await invoke(name, input);
      expect(a.status, `${name}: ${a.text}`).toBe(200);
      expect(a.type, name).toMatch(/^application\/json/);
      conforms(action.output, a.body, name);
    }
  });

  it("Synchronous Action Response: an error before responding is an Error Response (409 busy: problem details)", async () => {
    const moving = invoke("moveToJointPosition", { joints: FAR, speed: 0.2 });
    await waitState(s.things[0]!.tdUrl, "moving", 30_000, AUTH);
    isProblem(await invoke("moveToJointPosition", { joints: HOME }), 409);
    expect((await moving).status).toBe(200);
    expect((await invoke("moveToJointPosition", { joints: HOME, speed: 0.5 })).status).toBe(200);
  });

  it("Asynchronous Action Response: 201, Content-Type application/json, Location = the ActionStatus resource, the ActionStatus with href", async () => {
    const a = await invokeAsync("moveToJointPosition", { joints: FAR, speed: 0.5 });
    expect(a.status).toBe(201);
    expect(a.type).toMatch(/^application\/json/);
    const location = a.headers.get("location")!;
    expect(/^https?:$/.test(new URL(location).protocol)).toBe(true);
    expect(a.body.href).toBe(location);
    expect(STATUSES).toContain(a.body.status);
    expect(a.body.timeRequested).toMatch(RFC3339);
    await pollEnd(location);
    expect((await invoke("moveToJointPosition", { joints: HOME, speed: 0.5 })).status).toBe(200);
  });

  it("queryaction: GET on the ActionStatus resource answers 200, application/json, an ActionStatus (one of four statuses, RFC 3339 times, output per the action's output schema)", async () => {
    const a = await invokeAsync("moveToJointPosition", { joints: FAR, speed: 0.5 });
    const seen = new Set<string>();
    const st = await waitFor(
      async () => {
        const q = await request(a.body.href, { headers: { accept: "application/json" } });
        expect(q.status).toBe(200);
        expect(q.type).toMatch(/^application\/json/);
        expect(STATUSES).toContain(q.body.status);
        seen.add(q.body.status);
        return q.body.status !== "pending" && q.body.status !== "running" && q.body;
      },
      { intervalMs: 30, what: "the action's end" },
    );
    expect(st.status).toBe("completed");
    expect(seen.has("running")).toBe(true);
    expect(st.timeRequested).toMatch(RFC3339);
    expect(st.timeEnded).toMatch(RFC3339);
    conforms(td.actions.moveToJointPosition.output, st.output, "output");
    expect((await invoke("moveToJointPosition", { joints: HOME, speed: 0.5 })).status).toBe(200);
  });

  it('queryaction: a failed action\'s status is "failed" and its error is Problem Details (the synchronous answer: 422)', async () => {
    // a target the simulation refuses after the acceptance: the end effector would be inside a ball
    expect((await invoke("moveToJointPosition", { joints: FAR, speed: 0.5 })).status).toBe(200);
    const tcp = (await request(new URL("properties/getCartesianPosition", td.base).href)).body;
    expect((await invoke("moveToJointPosition", { joints: HOME, speed: 0.5 })).status).toBe(200);
    const ball = { name: "ball", shape: { type: "sphere", radius: 0.05 }, position: [tcp.x, tcp.y, tcp.z] };
    expect((await invoke("addObstacle", ball)).status).toBe(200);
    try {
      isProblem(await invoke("moveToJointPosition", { joints: FAR }), 422);
      const a = await invokeAsync("moveToJointPosition", { joints: FAR, speed: 0.5 });
      expect(a.status).toBe(201);
      const st = await pollEnd(a.body.href);
      expect(st.status).toBe("failed");
      expect(st.error).toMatchObject({ type: expect.any(String), title: expect.any(String), status: expect.any(Number), detail: expect.any(String) });
      expect(st.timeEnded).toMatch(RFC3339);
    } finally {
      expect((await invoke("removeObstacle", { name: "ball" })).status).toBe(200);
    }
  });

  it("cancelaction: DELETE answers 204; the cancelled invocation's ActionStatus is deleted (a query then answers 404)", async () => {
    const a = await invokeAsync("moveToJointPosition", { joints: FAR, speed: 0.2 });
    const cancel = formFor(td.actions.moveToJointPosition.forms, "cancelaction");
    const href = cancel.href.replace("{actionID}", a.body.href.split("/").pop());
    expect(href).toBe(a.body.href);
    // cancelled mid-motion
    await waitFor(async () => (await request(href, { headers: { accept: "application/json" } })).body.status === "running", { what: "the move running" });
    const d = await request(href, { method: "DELETE" });
    expect(d.status).toBe(204);
    expect(d.text).toBe("");
    isProblem(await request(href, { headers: { accept: "application/json" } }), 404);
    expect((await invoke("moveToJointPosition", { joints: HOME, speed: 0.5 })).status).toBe(200);
  });

  it("queryaction / cancelaction: an action that only answers synchronously has no ActionStatus resources", async () => {
    for (const name of ["stop", "validateJointPosition"]) {
      expect((td.actions[name].forms as Form[]).flatMap(ops).some((o) => o === "queryaction" || o === "cancelaction")).toBe(false);
      isProblem(await request(new URL(`actions/${name}/00000000-0000-0000-0000-000000000000`, td.base).href), 404);
    }
  });
});

describe("HTTP SSE Profile", () => {
  it("observeproperty: 200 text/event-stream; each message's event is the property's name, its data the value in JSON per the schema, an id set", async () => {
    for (const [name, p] of Object.entries(td.properties as Record<string, any>).filter(([, x]) => x.observable)) {
      const form = formFor(p.forms, "observeproperty", "sse");
      const stream = await openSse(form.href, { ...AUTH, connection: "keep-alive" });
      try {
        expect(stream.status, name).toBe(200);
        expect(stream.headers.get("content-type"), name).toContain("text/event-stream");
        await stream.wait((m) => m.some((x) => x.data !== null));
      } finally {
        stream.close();
      }
      const { forms: _f, observable: _o, ...schema } = p;
      for (const m of stream.messages.filter((x) => x.data !== null)) {
        expect(m.event).toBe(name);
        expect(m.id).toMatch(/^\d+$/);
        conforms(schema, JSON.parse(m.data!), name);
      }
    }
  });

  it("subscribeevent: 200 text/event-stream; each message's event is the event's name, its data per the event's data schema, an id set", async () => {
    const form = formFor(td.events.collision.forms, "subscribeevent", "sse");
    const stream = await openSse(form.href, { ...AUTH, connection: "keep-alive" });
    try {
      expect(stream.status).toBe(200);
      expect(stream.headers.get("content-type")).toContain("text/event-stream");
      // a real collision: a slow move into a box added on its way
      const from = (await joints()).lbr_iiwa_joint_2!;
      const move = invoke("moveToJointPosition", { joints: kukaPose([0, 1.2, 0, -0.4, 0, 0.4, 0]), speed: 0.05 });
      await waitFor(async () => Math.abs((await joints()).lbr_iiwa_joint_2! - from) > 0.02, { what: "the move running" });
      expect((await invoke("addObstacle", { name: "intruder", shape: { type: "box", size: [0.2, 0.6, 0.2] }, position: [0.55, 0, 0.75] })).status).toBe(200);
      expect((await move).body.status).toBe("collision");
      await stream.wait((m) => m.some((x) => x.data !== null));
    } finally {
      stream.close();
      await invoke("removeObstacle", { name: "intruder" });
    }
    for (const m of stream.messages.filter((x) => x.data !== null)) {
      expect(m.event).toBe("collision");
      expect(m.id).toMatch(/^\d+$/);
      conforms(td.events.collision.data, JSON.parse(m.data!), "collision");
    }
  });
});
