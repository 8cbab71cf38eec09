/**
 * `robwot asyncapi`: the document is valid for the official AsyncAPI parser (which is first shown to refuse
 * a broken one), and it describes what the servient really sends: every /live message of a move with a
 * wall in the way, an obstacle edit and a bad client message, and the SSE streams' data, each validated with an
 * independent JSON Schema validator (Ajv) against the payload schema the document gives its type.
 */
import { readFileSync } from "node:fs";
import { join } from "node:path";
import Ajv from "ajv";
import { afterAll, beforeAll, expect, it } from "vitest";
import { validateAsyncApi } from "../packages/cli/src/asyncapi.js";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { runCli } from "./cli-run.js";
import { openSse } from "./helpers/sse.js";
import { generateTwin, invoke, kukaPose, live } from "./serve-helpers.js";

let dir: string;
let servient: RunningServient;
let doc: any;

beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000);
  servient = await startServient({ twins: [dir], port: 0, realtime: 1 });
  const out = join(dir, "..", "asyncapi.json");
  const r = await runCli(["asyncapi", dir, "--base", `${servient.url}/`, "--out", out]);
  expect(r.code, r.stderr).toBe(0);
  doc = JSON.parse(readFileSync(out, "utf8"));
}, 180_000);
afterAll(async () => servient?.stop());

it("is valid for the official parser, which refuses a broken document", async () => {
  expect(await validateAsyncApi(doc)).toEqual([]);
  const broken = structuredClone(doc);
  broken.operations.receiveLive.action = "listen";
  delete broken.info;
  const errors = await validateAsyncApi(broken);
  expect(errors.length).toBeGreaterThan(0);
  expect(errors.join("\n")).toMatch(/info|action/);
  expect(doc.servers.live).toMatchObject({ host: new URL(servient.url).host, protocol: "ws", pathname: "/live" });
  const td = JSON.parse(readFileSync(join(dir, "td.json"), "utf8"));
  const sseForms = ["properties", "events"].flatMap((k) => Object.entries(td[k]).filter(([, a]: [string, any]) => a.forms.some((f: any) => f.subprotocol === "sse")).map(([n]) => `${k}.${n}`));
  expect(Object.keys(doc.channels).filter((c) => c !== "live").sort()).toEqual(sseForms.sort());
  expect(doc.channels["properties.getJointPosition"].address).toBe(`/${servient.things[0]!.slug}/properties/getJointPosition/sse`);
});

/** Ajv validators of the document's messages on `channel`, by message name. */
function validators(channel: string): Map<string, (v: unknown) => boolean> {
  const ajv = new Ajv({ strict: false, allErrors: true });
  const out = new Map<string, (v: unknown) => boolean>();
  for (const [name, m] of Object.entries(doc.channels[channel].messages as Record<string, { payload: object }>)) {
    const v = ajv.compile(m.payload);
    out.set(name, (x) => v(x) as boolean);
  }
  return out;
}

it("every /live message the servient sends validates against the payload of its type", async () => {
  const check = validators("live");
  const slug = servient.things[0]!.slug;
  const base = servient.things[0]!.tdUrl;
  const stream = await live(`${servient.liveUrl}?thing=${slug}`);
  try {
    await invoke(base, "addObstacle", { name: "wall", shape: { type: "box", size: [0.05, 1, 1] }, position: [0.45, 0, 0.5] });
    await invoke(base, "moveToJointPosition", { joints: kukaPose([0.3, 0.4, 0, -0.6, 0, 0.4, 0]), speed: 1 });
    await invoke(base, "removeObstacle", { name: "wall" });
    stream.ws.send(JSON.stringify({ subscribe: 42 }));
    await stream.waitFor((m) => m.type === "error");
  } finally {
    stream.close();
  }
  const types = new Set(stream.messages.map((m) => m.type));
  for (const t of ["joints", "status", "scene", "error"]) expect(types, `saw ${[...types].join(", ")}`).toContain(t);
  for (const m of stream.messages) {
    const v = check.get(m.type);
    expect(v, `a ${m.type} message the document does not describe`).toBeDefined();
    expect(v!(m), `${m.type}: ${JSON.stringify(m).slice(0, 200)}`).toBe(true);
  }
  // and the schemas are not vacuous: a joints message with a joint's value as text is refused
  const joints = stream.messages.find((m) => m.type === "joints");
  expect(check.get("joints")!({ ...joints, joints: { ...joints.joints, lbr_iiwa_joint_1: "0.3" } })).toBe(false);
}, 60_000);

it("the SSE streams' data validate against their channels' payloads", async () => {
  const base = servient.things[0]!.tdUrl;
  const check = validators("properties.getJointPosition");
  const stream = await openSse(`${servient.url}${doc.channels["properties.getJointPosition"].address}`);
  try {
    await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0.2, 0, -0.3, 0, 0.2, 0]), speed: 1 });
    await stream.wait((m) => m.filter((x) => x.data !== null).length >= 3);
  } finally {
    stream.close();
  }
  const values = stream.events().map((e) => e.data);
  expect(values.length).toBeGreaterThanOrEqual(3);
  for (const v of values) expect(check.get("getJointPosition")!(v)).toBe(true);
}, 60_000);
