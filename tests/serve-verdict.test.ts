/**
 * The simulation decides: a target the twin reaches collision-free is accepted even where the static
 * checks on the linked files (workspace.stl, point-cloud score) say otherwise — they are reported in
 * `checks` and `notes` — while a target beyond reach is still refused. Real servient, backend, HTTP.
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, rng } from "./serve-helpers.js";

let s: RunningServient;
let base: string;

beforeAll(async () => {
  // few samples: a coarse surface, so some reachable targets lie outside it
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 1000)], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

it("accepts reachable targets the static checks would have refused, refuses targets beyond reach", async () => {
  const random = rng(11);
  let disagreed = 0;
  for (let i = 0; i < 60 && disagreed < 3; i++) {
    const q = [0, 1, 2, 3, 4, 5, 6].map(() => (random() - 0.5) * 2.0);
    const pose = await invoke(base, "validateJointPosition", { joints: kukaPose(q) });
    if (!pose.body.valid) continue; // a self-colliding or blocked configuration: no target
    await invoke(base, "moveToJointPosition", { joints: kukaPose(q) });
    const p = (await http(`${base}/properties/getCartesianPosition`)).body;
    await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) });
    const r = await invoke(base, "validateCartesianPosition", { x: p.x, y: p.y, z: p.z });
    expect(r.status).toBe(200); // a reachable target is inside the TD's Cartesian bounds (the reach box)
    const staticOk = r.body.checks.insideWorkspace.ok && r.body.checks.pointCloud.ok;
    if (staticOk) continue;
    disagreed++;
    expect(r.body.checks.ik.ok).toBe(true);
    expect(r.body.valid).toBe(true);
    expect(r.body.notes.join(" ")).toMatch(/the simulation reaches it collision-free/);
  }
  expect(disagreed).toBeGreaterThan(0);
  const far = await invoke(base, "validateCartesianPosition", { x: 1.5, y: 1.5, z: 1.5 });
  expect(far.status).toBe(400); // beyond the TD's Cartesian bounds: refused by the schema already
  const unreachable = await invoke(base, "validateCartesianPosition", { x: 0, y: 0, z: 0.05 });
  expect(unreachable.body.valid).toBe(false);
});
