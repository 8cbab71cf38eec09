/**
 * End to end: with auth on (basic or bearer) every affordance, file and the /live socket needs
 * credentials, the TD's securityDefinitions say so, and a node-wot consumer with credentials works.
 */
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import WebSocket from "ws";
import { startServient, type AuthConfig, type RunningServient } from "../packages/servient/src/index.js";
import { consumer, generateTwin, http, invoke, kukaPose } from "./serve-helpers.js";

let dir: string;
beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
});

const upgrade = (url: string, headers: Record<string, string>): Promise<number> =>
  new Promise((resolve) => {
    const ws = new WebSocket(url, { headers });
    ws.once("open", () => {
      ws.close();
      resolve(101);
    });
    ws.once("unexpected-response", (_req, res) => resolve(res.statusCode ?? 0));
    ws.once("error", () => resolve(-1));
  });

const schemes: [string, AuthConfig, Record<string, string>, Record<string, string>, (id: string) => Record<string, unknown>][] = [
  [
    "basic",
    { scheme: "basic", user: "ada", password: "s3cret" },
    { authorization: `Basic ${Buffer.from("ada:s3cret").toString("base64")}` },
    { authorization: `Basic ${Buffer.from("ada:wrong").toString("base64")}` },
    (id) => ({ [id]: { username: "ada", password: "s3cret" } }),
  ],
  ["bearer", { scheme: "bearer", token: "tok-123" }, { authorization: "Bearer tok-123" }, { authorization: "Bearer nope" }, (id) => ({ [id]: { token: "tok-123" } })],
];

describe.each(schemes)("auth %s", (scheme, auth, good, bad, creds) => {
  let s: RunningServient;
  let base: string;
  beforeAll(async () => {
    s = await startServient({ twins: [dir], port: 0, realtime: 0, auth });
    base = `${s.url}/${s.things[0]!.slug}`;
  });
  afterAll(async () => s?.stop());

  it.each([
    ["the TD", ""],
    ["a property", "/properties/getJointPosition"],
    ["a file", "/robot.urdf"],
    ["the index", "/../robwot.json"],
  ])("refuses %s without or with wrong credentials (401 JSON) and serves it with them", async (_w, path) => {
    const url = new URL(`${base}${path}`).href;
    const none = await http(url);
    expect(none.status).toBe(401);
    expect(none.body.code).toBe("E_UNAUTHORIZED");
    expect((await http(url, { headers: bad })).status).toBe(401);
    expect((await http(url, { headers: good })).status).toBe(200);
  });

  it("refuses actions without credentials and the twin does not move", async () => {
    const before = (await http(`${base}/properties/getJointPosition`, { headers: good })).body;
    const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([0.2, 0.2, 0, -0.5, 0, 0, 0]) });
    expect(r.status).toBe(401);
    expect((await http(`${base}/properties/getJointPosition`, { headers: good })).body).toEqual(before);
    expect((await invoke(base, "moveToJointPosition", { joints: kukaPose([0.2, 0.2, 0, -0.5, 0, 0, 0]) }, good)).status).toBe(200);
  });

  it("says so in the TD's securityDefinitions", async () => {
    const td = (await http(base, { headers: good })).body;
    const def = td.securityDefinitions[Array.isArray(td.security) ? td.security[0] : td.security];
    expect(def.scheme).toBe(scheme);
  });

  it("guards the /live socket", async () => {
    expect(await upgrade(s.liveUrl, {})).toBe(401);
    expect(await upgrade(s.liveUrl, bad)).toBe(401);
    expect(await upgrade(s.liveUrl, good)).toBe(101);
  });

  it("serves a node-wot consumer that has the credentials", async () => {
    const td = (await http(base, { headers: good })).body;
    const c = await consumer(creds(td.id));
    try {
      const thing = await c.wot.consume(td);
      const joints = (await (await thing.readProperty("getJointPosition")).value()) as Record<string, number>;
      expect(Object.keys(joints)).toHaveLength(7);
      const r = (await (await thing.invokeAction("validateJointPosition", { joints }))!.value()) as { valid: boolean };
      expect(r.valid).toBe(true);
    } finally {
      await c.stop();
    }
  });
});
