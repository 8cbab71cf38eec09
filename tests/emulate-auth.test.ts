/**
 * `robwot emulate --auth` (the schemes and format of `robwot serve --auth`): without or with wrong
 * credentials everything answers 401 problem details, the TD included, and a jog does not move the robot;
 * the TD's securityDefinitions say what is required, and a node-wot consumer given the credentials by the
 * TD's id reads and commands it. Real emulator (its own backend), fetch and a node-wot consumer.
 */
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startEmulator, type AuthConfig, type RunningEmulator } from "../packages/servient/src/index.js";
import { consumer, generateTwin, http, invoke } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
let dir: string;
beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
});

const basic = (user: string, password: string): Record<string, string> => ({ authorization: `Basic ${Buffer.from(`${user}:${password}`).toString("base64")}` });

const schemes: [string, AuthConfig, Record<string, string>, Record<string, string>, (id: string) => Record<string, unknown>][] = [
  ["basic", { scheme: "basic", user: "ada", password: "s3:cret" }, basic("ada", "s3:cret"), basic("ada", "wrong"), (id) => ({ [id]: { username: "ada", password: "s3:cret" } })],
  ["bearer", { scheme: "bearer", token: "tok-123" }, { authorization: "Bearer tok-123" }, { authorization: "Bearer nope" }, (id) => ({ [id]: { token: "tok-123" } })],
];

describe.each(schemes)("--auth %s", (scheme, auth, good, bad, creds) => {
  let robot: RunningEmulator;
  beforeAll(async () => {
    robot = await startEmulator({ folder: dir, port: 0, auth });
  });
  afterAll(async () => robot?.stop());

  const joints = async (): Promise<Record<string, number>> => (await http(`${robot.tdUrl}/properties/getJointPosition`, { headers: good })).body;

  it.each([
    ["the TD", ""],
    ["a property", "/properties/getJointPosition"],
    ["all properties", "/properties"],
  ])("refuses %s without or with wrong credentials (401 problem details) and serves it with them", async (_w, path) => {
    const url = `${robot.tdUrl}${path}`;
    const none = await http(url);
    expect(none.status).toBe(401);
    expect(none.type).toBe("application/problem+json");
    expect(none.body.code).toBe("E_UNAUTHORIZED");
    expect(none.headers.get("www-authenticate")).toMatch(new RegExp(`^${scheme}`, "i"));
    expect((await http(url, { headers: bad })).status).toBe(401);
    expect((await http(url, { headers: good })).status).toBe(200);
  });

  it("refuses a jog without credentials and the robot does not move; with them it moves", async () => {
    const before = await joints();
    for (const headers of [{}, bad]) {
      const r = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 0.5 }, duration: 0.2 }, headers);
      expect(r.status).toBe(401);
    }
    expect(await joints()).toEqual(before);
    // the marker that the refused jogs are over: had one run, this jog would find the robot busy (409) or
    // end further on than its own 0.1 rad
    const r = await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 0.5 }, duration: 0.2 }, good);
    expect(r.status, JSON.stringify(r.body)).toBe(200);
    expect((await joints())[J1]! - before[J1]!).toBeCloseTo(0.1, 1);
  });

  it("says so in the TD's securityDefinitions", async () => {
    const td = (await http(robot.tdUrl, { headers: good })).body;
    const name = Array.isArray(td.security) ? td.security[0] : td.security;
    expect(td.securityDefinitions[name].scheme).toBe(scheme);
    expect(Object.values(td.securityDefinitions).map((d: any) => d.scheme)).not.toContain("nosec");
  });

  it("serves a node-wot consumer that has the credentials", async () => {
    const td = (await http(robot.tdUrl, { headers: good })).body;
    const c = await consumer(creds(td.id));
    try {
      const thing = await c.wot.consume(td);
      const before = (await (await thing.readProperty("getJointPosition")).value()) as Record<string, number>;
      expect(Object.keys(before)).toHaveLength(7);
      const r = (await (await thing.invokeAction("jog", { velocities: { [J1]: -0.5 }, duration: 0.2 }))!.value()) as { status: string; joints: Record<string, number> };
      expect(r.status).toBe("reached");
      expect(r.joints[J1]! - before[J1]!).toBeCloseTo(-0.1, 1);
      expect(((await (await thing.readProperty("motionStatus")).value()) as { state: string }).state).toBe("idle");
      expect((await (await thing.invokeAction("stop"))!.value()) as unknown).toEqual({ stopped: false });
    } finally {
      await c.stop();
    }
  });
});
