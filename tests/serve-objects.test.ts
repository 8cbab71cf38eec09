/**
 * End to end: a twin generated with a scene holding objects (examples/scenes/objects.json) serves them
 * where they rest (the `objects` property, /live `scene` messages), refuses a move into one naming it, and
 * adds, moves and removes objects, each settled by the real backend.
 */
import { readFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { REPO } from "./cli-run.js";
import { generateTwin, http, invoke, live } from "./serve-helpers.js";

interface RestingObject {
  name: string;
  shape: { type: string };
  position: number[];
  orientation: number[];
  mass: number;
  color?: number[];
}

let s: RunningServient;
let base: string;
let dir: string;
beforeAll(async () => {
  dir = await generateTwin("kuka_iiwa", 3000, ["--scene", join(REPO, "examples", "scenes", "objects.json")]);
  s = await startServient({ twins: [dir], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

const byName = (list: RestingObject[]): Record<string, RestingObject> => Object.fromEntries(list.map((o) => [o.name, o]));

it("serves the scene's objects where they came to rest, as generate wrote them", async () => {
  const written = JSON.parse(readFileSync(join(dir, "scene.json"), "utf8")) as { objects: RestingObject[] };
  expect(written.objects.map((o) => o.name)).toEqual(["cube", "cup", "crate"]);
  const r = await http(`${base}/properties/objects`);
  expect(r.status).toBe(200);
  const objects = byName(r.body as RestingObject[]);
  // let go at z = 0.5 m: the cube and the cup on the table's top (0.3 m), the crate on the floor
  expect(objects["cube"]!.position[2]).toBeCloseTo(0.325, 2);
  expect(objects["cup"]!.position[2]).toBeCloseTo(0.35, 2);
  expect(objects["crate"]!.position[2]).toBeCloseTo(0.2, 2);
  expect(objects["cube"]!.mass).toBe(0.2);
  expect(objects["cube"]!.color).toEqual([0.9, 0.1, 0.1]);
  expect(objects["crate"]!.orientation).toHaveLength(4);
  const td = (await http(base)).body;
  expect(td.properties.objects.observable).toBe(true);
  expect(Object.keys(td.actions)).toEqual(expect.arrayContaining(["addObject", "moveObject", "removeObject"]));
});

it("refuses a move into an object, naming it", async () => {
  const target = { x: 0.0, y: 0.6, z: 0.3 }; // inside the crate
  const checked = await invoke(base, "validateCartesianPosition", target);
  expect(checked.status).toBe(200);
  expect(checked.body.valid).toBe(false);
  expect(checked.body.reasons.join(" ")).toContain("crate");
  const moved = await invoke(base, "moveToCartesianPosition", target);
  expect(moved.status).toBe(422);
  expect(moved.body.code).toBe("E_REJECTED");
  expect(JSON.stringify(moved.body.details.reasons)).toContain("crate");
});

it("adds, moves and removes objects, each settled, and pushes their poses over /live", async () => {
  const slug = s.things[0]!.slug;
  const ws = await live(s.liveUrl);
  try {
    ws.ws.send(JSON.stringify({ subscribe: slug }));
    const snap = await ws.waitFor((m) => m.type === "scene");
    expect(Object.keys(byName(snap.objects))).toEqual(["cube", "cup", "crate"]);

    const ball = { name: "ball", shape: { type: "sphere", radius: 0.03 }, position: [0.8, 0.0, 0.6], color: [0, 0.8, 0] };
    const added = await invoke(base, "addObject", ball);
    expect(added.status).toBe(200);
    expect(added.body.position[2]).toBeGreaterThan(0.3);
    expect(added.body.position[2]).toBeLessThan(0.34); // on the table
    const pushed = await ws.waitFor((m) => m.type === "scene" && m.objects.some((o: RestingObject) => o.name === "ball"));
    expect(byName(pushed.objects)["ball"]!.position).toEqual(added.body.position);

    const moved = await invoke(base, "moveObject", { name: "ball", position: [-0.6, 0.0, 0.4] });
    expect(moved.status).toBe(200);
    expect(moved.body.position[2]).toBeCloseTo(0.03, 2); // on the floor
    await ws.waitFor((m) => m.type === "scene" && m.objects.some((o: RestingObject) => o.name === "ball" && (o.position[0] ?? 0) < 0));

    const into = await invoke(base, "moveObject", { name: "ball", position: [0.7, 0.0, 0.2] });
    expect(into.status).toBe(409);
    expect(into.body.code).toBe("E_OVERLAP");
    expect(into.body.message).toContain("table");
    const taken = await invoke(base, "addObject", { ...ball, name: "table" });
    expect(taken.status).toBe(409);
    expect((await invoke(base, "removeObject", { name: "table" })).status).toBe(404);
    expect((await invoke(base, "removeObject", { name: "ball" })).status).toBe(200);
    const objects = (await http(`${base}/properties/objects`)).body as RestingObject[];
    expect(objects.map((o) => o.name)).toEqual(["cube", "cup", "crate"]);
  } finally {
    ws.close();
  }
});
