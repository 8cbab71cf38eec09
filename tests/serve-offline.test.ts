/**
 * End to end: any consumer can validate targets offline from the TD's linked files (workspace.stl,
 * workspace.csv, reachability.csv) with @robwot/core, no Python; its answers agree with the twin's own
 * validateCartesianPosition on 6,000 points (>= 99.9% for points farther than 1 cm from the surface; each
 * validation is a full simulation-in-the-loop plan: 10,000 took 186 s alone on 2 busy cores, but more
 * than 600 s beside the rest of the suite).
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { loadWorkspaceFromUrls, REACHABILITY_REL, type Vec3 } from "../packages/core/src/index.js";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, rng } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0 });
  base = `${s.url}/${s.things[0]!.slug}`;
});
afterAll(async () => s?.stop());

it("offline checks from the linked files agree with the twin on 6,000 points", async () => {
  const td = (await http(base)).body;
  const href = (rel: string): string => new URL(td.links.find((l: { rel: string }) => l.rel === rel).href, td.base).href;
  const ws = await loadWorkspaceFromUrls(href("workspace"), href("workspace-pointcloud"), undefined, { csvUrl: href(REACHABILITY_REL), summaryUrl: href("workspace-summary") });
  const input = td.actions.validateCartesianPosition.input.properties;
  const lo = [input.x.minimum, input.y.minimum, input.z.minimum] as Vec3;
  const hi = [input.x.maximum, input.y.maximum, input.z.maximum] as Vec3;
  const u = rng(2024);
  const points: Vec3[] = Array.from({ length: 6_000 }, () => [0, 1, 2].map((k) => lo[k]! + u() * (hi[k]! - lo[k]!)) as Vec3);

  let compared = 0;
  let insideAgree = 0;
  let cloudAgree = 0;
  let reachAgree = 0;
  let reached = 0;
  let inside = 0;
  let next = 0;
  const worker = async (): Promise<void> => {
    while (next < points.length) {
      const p = points[next++]!;
      const r = await invoke(base, "validateCartesianPosition", { x: p[0], y: p[1], z: p[2] });
      expect(r.status).toBe(200);
      if (ws.mesh.distanceToSurface(p) <= 0.01) continue;
      const offline = ws.check(p);
      // the same map, read by the same code: identical answers, not merely agreeing ones
      expect(r.body.checks.reachability).toEqual(offline.reachability);
      reachAgree++;
      if (offline.reachability!.ok) reached++;
      compared++;
      if (offline.insideWorkspace) inside++;
      if (r.body.checks.insideWorkspace.ok === offline.insideWorkspace) insideAgree++;
      if (r.body.checks.pointCloud.ok === offline.pointCloud.ok) cloudAgree++;
    }
  };
  await Promise.all(Array.from({ length: 4 }, worker));
  expect(compared).toBeGreaterThan(4_800);
  expect(inside).toBeGreaterThan(450);
  expect(compared - inside).toBeGreaterThan(450);
  expect(insideAgree / compared).toBeGreaterThanOrEqual(0.999);
  expect(cloudAgree / compared).toBeGreaterThanOrEqual(0.999);
  expect(reachAgree).toBe(compared);
  expect(reached).toBeGreaterThan(375);
}, 900_000);
