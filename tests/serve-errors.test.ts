/**
 * End to end: mistakes a newcomer makes with curl get a JSON answer that says what is wrong:
 * an unknown affordance name (404 naming the available ones) and a non-JSON content type on an
 * action (415 naming the header to send), instead of node-wot's bare 404 / 415; a string longer than the
 * backend accepts is refused by the TD's schema naming the limit; a title node-wot cannot route is refused.
 */
import { readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 500)], port: 0, realtime: 0 });
  base = `${s.url}/${s.things[0]!.slug}`;
});
afterAll(async () => s?.stop());

it("an unknown property, action or event answers 404 JSON listing the available names", async () => {
  const p = await http(`${base}/properties/jointPosition`);
  expect(p.status).toBe(404);
  expect(p.body).toMatchObject({ code: "E_NOT_FOUND", message: expect.stringContaining("jointPosition") });
  expect(p.body.details.available).toContain("getJointPosition");
  const a = await http(`${base}/actions/movetoCartesianPosition`, {
    method: "POST",
    headers: { "content-type": "application/json" },
    body: JSON.stringify({ x: 0.4, y: 0.1, z: 0.5 }),
  });
  expect(a.status).toBe(404);
  expect(a.body.details.available).toContain("moveToCartesianPosition");
  const e = await http(`${base}/events/collisions`);
  expect(e.status).toBe(404);
  expect([...e.body.details.available].sort()).toEqual(["collision", "collisionImminent", "divergence"]);
  // known names still work
  expect((await http(`${base}/properties/getJointPosition`)).status).toBe(200);
}, 300_000);

it("an action body sent as a form (curl -d without a content type) answers 415 JSON naming the header", async () => {
  const before = (await http(`${base}/properties/getJointPosition`)).body;
  const r = await http(`${base}/actions/moveToCartesianPosition`, {
    method: "POST",
    headers: { "content-type": "application/x-www-form-urlencoded" },
    body: JSON.stringify({ x: 0.4, y: 0.1, z: 0.5 }),
  });
  expect(r.status).toBe(415);
  expect(r.body).toMatchObject({ code: "E_UNSUPPORTED_MEDIA_TYPE", message: expect.stringContaining("application/json") });
  expect((await http(`${base}/properties/getJointPosition`)).body).toEqual(before);
}, 300_000);

it("every string input carries the backend's length limit, and a longer one is refused naming it", async () => {
  const td = (await http(base)).body;
  const name = td.actions.addObstacle.input.properties.name;
  expect(name.maxLength).toBe(200);
  expect(td.actions.removeObstacle.input.properties.name.maxLength).toBe(200);
  expect(td.actions.addObstacle.input.properties.shape.properties.file.maxLength).toBe(4096);
  const box = { shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [2, 2, 0.05] };
  const long = await invoke(base, "addObstacle", { ...box, name: "n".repeat(201) });
  expect(long.status).toBe(400);
  expect(long.body.message).toMatch(/200/);
  const ok = await invoke(base, "addObstacle", { ...box, name: "n".repeat(200) });
  expect(ok.status).toBe(200);
  expect((await invoke(base, "removeObstacle", { name: "n".repeat(200) })).status).toBe(200);
}, 300_000);

it("a twin folder whose title is too long to be routed is refused; the longest routable one serves stop", async () => {
  const dir = await generateTwin("kuka_iiwa", 500);
  const tdFile = join(dir, "td.json");
  const original = JSON.parse(readFileSync(tdFile, "utf8"));
  writeFileSync(tdFile, JSON.stringify({ ...original, title: "k".repeat(124) }));
  await expect(startServient({ twins: [dir], port: 0, realtime: 0 })).rejects.toMatchObject({
    code: "E_TWIN_FOLDER",
    message: expect.stringMatching(/124 characters; at most 100/),
  });
  writeFileSync(tdFile, JSON.stringify({ ...original, title: "k".repeat(100) }));
  const served = await startServient({ twins: [dir], port: 0, realtime: 0 });
  try {
    const stop = await invoke(`${served.url}/${"k".repeat(100)}`, "stop", {});
    expect(stop.status).toBe(200);
    expect(typeof stop.body.stopped).toBe("boolean");
  } finally {
    await served.stop();
  }
}, 300_000);
