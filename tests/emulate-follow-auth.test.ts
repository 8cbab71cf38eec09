/**
 * A twin relaying to and following an emulated robot served with `--auth basic`: the credentials go in the
 * --relay URL's userinfo (the servient sends them as `Authorization: Basic` and shows the URL without
 * them); the twin mirrors the robot's jog and relays its moves. Real emulator, servient, backends and HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startEmulator, startServient, type RunningEmulator, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, waitFor } from "./serve-helpers.js";

const J1 = "lbr_iiwa_joint_1";
const AUTH = { authorization: `Basic ${Buffer.from("ada:s3cret").toString("base64")}` };
let robot: RunningEmulator;
let twin: RunningServient;

beforeAll(async () => {
  robot = await startEmulator({ folder: await generateTwin("kuka_iiwa", 3000), port: 0, auth: { scheme: "basic", user: "ada", password: "s3cret" } });
  const u = new URL(robot.tdUrl);
  u.username = "ada";
  u.password = "s3cret";
  twin = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0, relay: u.href, followRate: 50 });
});
afterAll(async () => {
  await twin?.stop();
  await robot?.stop();
});

it("mirrors the secured robot's jog and relays a move to it", async () => {
  const base = twin.things[0]!.tdUrl;
  const from = ((await http(`${robot.tdUrl}/properties/getJointPosition`, { headers: AUTH })).body as Record<string, number>)[J1]!;
  expect((await invoke(robot.tdUrl, "jog", { velocities: { [J1]: 0.6 }, duration: 0.5 }, AUTH)).status).toBe(200);
  const physical = await waitFor(
    async () => {
      const state = (await http(`${base}/properties/physicalState`)).body;
      const q = (await http(`${base}/properties/getJointPosition`)).body as Record<string, number>;
      return Math.abs(q[J1]! - (from + 0.3)) < 0.02 && state.followed > 0 && state;
    },
    { what: "the twin following the jog" },
  );
  expect(JSON.stringify(physical)).not.toContain("s3cret");
  const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([0.2, 0.1, 0, -0.4, 0, 0.2, 0]), speed: 0.5 });
  expect(r.body.relay?.ok, JSON.stringify(r.body)).toBe(true);
  const q = (await http(`${robot.tdUrl}/properties/getJointPosition`, { headers: AUTH })).body as Record<string, number>;
  expect(q[J1]).toBeCloseTo(0.2, 3);
});
