/**
 * End to end: several twin folders in one serve share one world; each robot is an obstacle for the
 * other in validation, and both are served as separate Things (same robot twice: unique slugs and ids).
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose, placeTwin } from "./serve-helpers.js";

let s: RunningServient;
beforeAll(async () => {
  const a = await generateTwin("kuka_iiwa", 3000);
  const b = await generateTwin("kuka_iiwa", 3000);
  placeTwin(b, Math.PI, [1.0, 0, 0]);
  s = await startServient({ twins: [a, b], port: 0, realtime: 0 });
});
afterAll(async () => s?.stop());

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
