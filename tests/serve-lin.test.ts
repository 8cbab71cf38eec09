/**
 * `motion: "lin"` / `"circ"` on validateCartesianPosition / moveToCartesianPosition: the twin moves its end effector
 * on the straight line or the arc through a via point (the backend's LIN / CIRC), says so in its answer, and the TD's schema takes only ptp/lin/circ.
 */
import { readFileSync, writeFileSync } from "node:fs";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { generateTwin, http, invoke, kukaPose } from "./serve-helpers.js";

let s: RunningServient;
let base: string;
beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0 });
  base = s.things[0]!.tdUrl;
});
afterAll(async () => s?.stop());

it("validates and moves along the straight line, answering path 'lin'", async () => {
  const start = await invoke(base, "moveToJointPosition", { joints: kukaPose([0, 0.6, 0, -1.2, 0, 0.6, 0]) });
  expect(start.status).toBe(200);
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  const target = { x: p.x, y: p.y + 0.15, z: p.z - 0.05, motion: "lin" };
  const v = await invoke(base, "validateCartesianPosition", target);
  expect(v.status).toBe(200);
  expect(v.body.valid).toBe(true);
  expect(v.body.checks.path.planned).toBe("lin");
  const m = await invoke(base, "moveToCartesianPosition", target);
  expect(m.status).toBe(200);
  expect(m.body.status).toBe("reached");
  expect(m.body.path).toBe("lin");
  expect(m.body.positionError).toBeLessThan(1e-3);
  const td = (await http(base)).body;
  expect(td.actions.moveToCartesianPosition.input.properties.motion.enum).toEqual(["ptp", "lin", "circ"]);
});

it("moves on the arc through a via point (circ); a circ without one is refused", async () => {
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  const via = { x: p.x, y: p.y + 0.08, z: p.z + 0.08 };
  const arc = { x: p.x, y: p.y + 0.16, z: p.z, motion: "circ", via };
  const v = await invoke(base, "validateCartesianPosition", arc);
  expect(v.status).toBe(200);
  expect(v.body.valid).toBe(true);
  expect(v.body.checks.path.planned).toBe("circ");
  const m = await invoke(base, "moveToCartesianPosition", arc);
  expect(m.status).toBe(200);
  expect(m.body.path).toBe("circ");
  expect(m.body.positionError).toBeLessThan(1e-3);
  const missing = await invoke(base, "validateCartesianPosition", { x: p.x, y: p.y, z: p.z, motion: "circ" });
  expect(missing.status).toBe(400);
});

it("refuses a motion the schema does not know, and a LIN out of reach with where it leaves it", async () => {
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  const bad = await invoke(base, "validateCartesianPosition", { x: p.x, y: p.y, z: p.z, motion: "spline" });
  expect(bad.status).toBe(400);
  const far = await invoke(base, "validateCartesianPosition", { x: p.x, y: p.y, z: Math.max(p.z - 0.8, -0.3), motion: "lin" });
  expect(far.status).toBe(200);
  expect(far.body.valid).toBe(false);
  expect(far.body.reasons[0]).toMatch(/^LIN refused: /);
});

it("validateProgram: PTP, LIN and CIRC steps planned one after the other, with durations and the cycle time", async () => {
  const home = kukaPose([0, 0.6, 0, -1.2, 0, 0.6, 0]);
  expect((await invoke(base, "moveToJointPosition", { joints: home })).status).toBe(200);
  const p = (await http(`${base}/properties/getCartesianPosition`)).body;
  const before = (await http(`${base}/properties/getJointPosition`)).body;
  const steps = [
    { joints: home, speed: 0.5 },
    { motion: "lin", x: p.x, y: p.y + 0.12, z: p.z },
    { motion: "circ", via: { x: p.x, y: p.y + 0.06, z: p.z + 0.05 }, x: p.x, y: p.y, z: p.z },
  ];
  const r = await invoke(base, "validateProgram", { steps });
  expect(r.status).toBe(200);
  expect(r.body.valid).toBe(true);
  expect(r.body.firstFailingStep).toBeUndefined();
  expect(r.body.steps.map((s: { planned: string }) => s.planned)).toEqual(["straight", "lin", "circ"]);
  expect(r.body.cycleTime).toBeCloseTo(r.body.steps.reduce((t: number, s: { duration: number }) => t + s.duration, 0), 9);
  expect(r.body.trajectory.names).toHaveLength(7);
  expect((await http(`${base}/properties/getJointPosition`)).body).toEqual(before); // nothing moved
  const both = await invoke(base, "validateProgram", { steps: [{ joints: home, x: p.x, y: p.y, z: p.z }] });
  expect(both.status).toBe(400);
  expect(JSON.stringify(both.body)).toContain("steps[0]: give joints (a PTP step) or x, y, z, not both");
});

it("a twin folder generated before validateProgram existed is still served, without that action", async () => {
  const dir = await generateTwin("kuka_iiwa", 3000);
  const td = JSON.parse(readFileSync(join(dir, "td.json"), "utf8"));
  delete td.actions.validateProgram;
  writeFileSync(join(dir, "td.json"), JSON.stringify(td));
  const old = await startServient({ twins: [dir], port: 0, realtime: 0 });
  try {
    const url = old.things[0]!.tdUrl;
    expect((await http(url)).body.actions.validateProgram).toBeUndefined();
    expect((await invoke(url, "validateProgram", { steps: [] })).status).toBe(404);
    expect((await invoke(url, "validateJointPosition", { joints: kukaPose([0, 0, 0, 0, 0, 0, 0]) })).status).toBe(200);
  } finally {
    await old.stop();
  }
});
