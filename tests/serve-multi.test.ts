/**
 * End to end: several twin folders in one serve share one world; each robot is an obstacle for the
 * other in validation, and both are served as separate Things (same robot twice: unique slugs and ids).
 * The /live scene message carries the whole world's obstacles, a scene-file mesh as a URL of its folder.
 */
import { mkdirSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { writeStl } from "../packages/core/src/index.js";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, live, placeTwin } from "./serve-helpers.js";

let s: RunningServient;
const overlaps: string[] = [];
const onWarning = (w: Error & { code?: string }): void => void (w.code === "ROBWOT_TWINS_OVERLAP" && overlaps.push(w.message));
beforeAll(async () => {
  process.on("warning", onWarning);
  const a = await generateTwin("kuka_iiwa", 3000);
  const b = await generateTwin("kuka_iiwa", 3000);
  placeTwin(b, Math.PI, [1.0, 0, 0]);
  // B's folder holds a mesh obstacle (a small tetrahedron far from both robots), as generate writes it
  mkdirSync(join(b, "meshes", "scene"), { recursive: true });
  const tetra = [0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0, 0, 0, 0, 0, 0.1, 0.1, 0, 0, 0, 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0.1, 0, 0, 0, 0, 0.1, 0, 0.1, 0];
  writeFileSync(join(b, "meshes", "scene", "rock-tetra.stl"), writeStl(tetra));
  const rock = { name: "rock", shape: { type: "mesh", file: "meshes/scene/rock-tetra.stl" }, position: [0, 3, 0] };
  writeFileSync(join(b, "scene.json"), JSON.stringify({ version: 1, obstacles: [rock], robots: [] }));
  s = await startServient({ twins: [a, b], port: 0, realtime: 0 });
});
afterAll(async () => {
  process.off("warning", onWarning);
  await s?.stop();
});

it("says at start that the two twins can touch each other", async () => {
  await new Promise((r) => setImmediate(r)); // process warnings are emitted on the next tick
  expect(overlaps).toHaveLength(1);
  expect(overlaps[0]).toMatch(/robwot serve: twin lbr_iiwa(_2)? stands within twin lbr_iiwa(_2)?'s reach \(1\.000 m apart\)|can reach into the same space/);
});

it("serves both twins and lets each see the other as an obstacle", async () => {
  expect(s.things.map((t) => t.slug)).toEqual(["lbr_iiwa", "lbr_iiwa_2"]);
  expect(new Set(s.things.map((t) => t.id)).size).toBe(2);
  const [a, b] = s.things.map((t) => `${s.url}/${t.slug}`) as [string, string];
  expect((await http(`${s.url}/robwot.json`)).body.things).toHaveLength(2);

  // A stretched towards B (x = +1 m): its forearm passes through B's base and upper links
  const reach = kukaPose([0, 1.45, 0, 0, 0, 0, 0]);
  const v = await invoke(a, "validateJointPosition", { joints: reach });
  expect(v.status).toBe(200);
  expect(v.body.valid).toBe(false);
  const bodies = v.body.checks.path.contacts.flatMap((c: any) => [c.a.body, c.b.body]);
  expect(bodies).toContain(s.twins.get("lbr_iiwa_2")!.robotId);

  // B moving its arm towards A changes the answer for a target A could reach before
  const nearB = kukaPose([0, 1.0, 0, -0.4, 0, 0.3, 0]);
  const before = (await invoke(a, "validateJointPosition", { joints: nearB })).body.valid;
  const bReaches = await invoke(b, "moveToJointPosition", { joints: kukaPose([0, 1.2, 0, -0.3, 0, 0.3, 0]) });
  expect(bReaches.status).toBe(200);
  const after = (await invoke(a, "validateJointPosition", { joints: nearB })).body.valid;
  expect(before).toBe(true);
  expect(after).toBe(false);
});

it("sends every subscriber the shared world's obstacles, mesh files as URLs of the folder holding them", async () => {
  const ws = await live(`${s.liveUrl}?thing=lbr_iiwa`);
  try {
    const scene = await ws.waitFor((m) => m.type === "scene");
    expect(scene.thing).toBe("lbr_iiwa");
    expect(scene.obstacles).toEqual([{ name: "rock", shape: { type: "mesh", file: "/lbr_iiwa_2/meshes/scene/rock-tetra.stl" }, position: [0, 3, 0] }]);
    const file = await fetch(new URL(scene.obstacles[0].shape.file, s.url));
    expect(file.status).toBe(200);
    expect((await file.arrayBuffer()).byteLength).toBe(84 + 4 * 50);
    // an edit through either twin reaches the subscribers of both
    ws.ws.send(JSON.stringify({ subscribe: "lbr_iiwa_2" }));
    await ws.waitFor((m) => m.type === "scene" && m.thing === "lbr_iiwa_2");
    expect((await invoke(`${s.url}/lbr_iiwa_2`, "moveObstacle", { name: "rock", position: [0, 3.5, 0] })).status).toBe(200);
    for (const thing of ["lbr_iiwa", "lbr_iiwa_2"]) {
      const m = await ws.waitFor((x) => x.type === "scene" && x.thing === thing && x.obstacles[0]?.position[1] === 3.5);
      expect(m.obstacles[0].shape.file).toBe("/lbr_iiwa_2/meshes/scene/rock-tetra.stl");
    }
  } finally {
    ws.close();
  }
});
