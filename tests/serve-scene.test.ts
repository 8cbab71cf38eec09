/**
 * End to end: the scene of a twin folder (generated with `--scene`) is loaded into the served world, and
 * scene edits change the validation answers and reach /live subscribers as `scene` messages; oversized
 * bodies are refused without harm.
 */
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO } from "./cli-run.js";
import { generateTwin, invoke, kukaPose, live } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
beforeAll(async () => {
  const dir = await generateTwin("kuka_iiwa", 3000, ["--scene", join(REPO, "examples", "scenes", "table.json")]);
  s = await startServient({ twins: [dir], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

it("pushes the scene over /live: a snapshot on subscribe, then every add, move and remove", async () => {
  const slug = s.things[0]!.slug;
  const ws = await live(s.liveUrl);
  try {
    ws.ws.send(JSON.stringify({ subscribe: slug }));
    const names = (m: any): string[] => m.obstacles.map((o: { name: string }) => o.name);
    const snap = await ws.waitFor((m) => m.type === "scene");
    expect(snap.thing).toBe(slug);
    expect(names(snap)).toContain("table");
    const table = snap.obstacles.find((o: { name: string }) => o.name === "table");
    expect(table.shape.type).toBeTypeOf("string");
    expect(table.position).toHaveLength(3);

    const crate = { name: "crate", shape: { type: "box", size: [0.1, 0.2, 0.3] }, position: [0.6, 0.4, 0.15] };
    expect((await invoke(base, "addObstacle", crate)).status).toBe(200);
    const added = await ws.waitFor((m) => m.type === "scene" && names(m).includes("crate"));
    const c = added.obstacles.find((o: { name: string }) => o.name === "crate");
    expect(c.shape).toEqual(crate.shape);
    expect(c.position).toEqual(crate.position);

    expect((await invoke(base, "moveObstacle", { name: "crate", position: [0.6, -0.4, 0.15] })).status).toBe(200);
    const moved = await ws.waitFor((m) => m.type === "scene" && m.obstacles.some((o: any) => o.name === "crate" && o.position[1] === -0.4));
    expect(names(moved)).toContain("table");

    // a refused edit changes nothing and sends nothing
    const before = ws.messages.filter((m) => m.type === "scene").length;
    expect((await invoke(base, "removeObstacle", { name: "nope" })).status).toBe(404);
    expect((await invoke(base, "removeObstacle", { name: "crate" })).status).toBe(200);
    // the first scene message after `before` is the removal's (the refused edit sent none)
    const removed = await ws.waitFor((m) => m.type === "scene" && ws.messages.filter((x) => x.type === "scene").indexOf(m) === before);
    expect(names(removed)).not.toContain("crate");
    expect(names(removed)).toContain("table");
  } finally {
    ws.close();
  }
});

it("validates against the folder's scene and its run-time edits", async () => {
  const down = kukaPose([0, 2.0, 0, 0, 0, 0, 0]);
  const r = await invoke(base, "validateJointPosition", { joints: down });
  expect(r.body.valid).toBe(false);
  const bodies = r.body.checks.path.contacts.flatMap((c: { a: { body: string }; b: { body: string } }) => [c.a.body, c.b.body]);
  expect(bodies).toContain("table");
  const below = await invoke(base, "validateCartesianPosition", { x: 0.5, y: 0, z: -0.02 });
  expect(below.body.valid).toBe(false);
  expect(below.body.checks.insideWorkspace.ok).toBe(false);

  const removed = await invoke(base, "removeObstacle", { name: "table" });
  expect(removed.status).toBe(200);
  const again = await invoke(base, "validateJointPosition", { joints: kukaPose([0, 1.0, 0, 0, 0, 0, 0]) });
  expect(again.body.valid).toBe(true);
});

it("refuses a body over 1 MB with 413 JSON and keeps serving", async () => {
  const big = JSON.stringify({ x: 0.5, y: 0, z: 0.5, pad: "x".repeat(1_100_000) });
  const r = await invoke(base, "validateCartesianPosition", big);
  expect(r.status).toBe(413);
  expect(r.body.code).toBe("E_TOO_LARGE");
  expect((await invoke(base, "stop", "")).status).toBe(200);
});
