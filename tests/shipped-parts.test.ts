/**
 * The bundled robots' convex parts ship with the package (sim-backend/src/robwot_sim/data/collision,
 * written by `npm run ship:parts`): every bundled robot loads from an empty collision cache without
 * decomposing (`decompose: false` refuses a concave mesh without parts), and the shipped folders are
 * exactly those the bundled robots use (a parameter or mesh change leaves them stale: this fails).
 */
import { existsSync, mkdtempSync, readdirSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, expect, it } from "vitest";
import { launchBackend, type LaunchedBackend } from "@robwot/sim-client";
import { EXAMPLE_ROBOTS, exampleUrdfPath } from "../packages/cli/src/examples.js";

const SHIPPED = join(import.meta.dirname, "..", "sim-backend/src/robwot_sim/data/collision");
let work: string;
let backend: LaunchedBackend;

beforeAll(async () => {
  work = mkdtempSync(join(tmpdir(), "robwot-shipped-"));
  backend = await launchBackend({ env: { ROBWOT_COLLISION_CACHE: join(work, "cache") } });
});
afterAll(async () => {
  await backend?.stop();
  rmSync(work, { recursive: true, force: true });
});

it("every bundled robot loads from an empty cache with the shipped parts, and no shipped folder is unused", async () => {
  const { pybulletData } = await backend.client.ping();
  const used = new Set<string>();
  for (const robot of EXAMPLE_ROBOTS) {
    const model = await backend.client.loadRobot({ urdf: exampleUrdfPath(robot, pybulletData), id: robot.name, decompose: false });
    const out = join(work, "export", robot.name);
    await backend.client.exportRobot({ robot: model.id, outDir: out });
    if (readdirSync(out).includes("collision")) for (const f of readdirSync(join(out, "collision"))) used.add(f);
  }
  expect([...used].sort()).toEqual(readdirSync(SHIPPED).sort());
  // nothing was decomposed: the cache was never even created
  expect(existsSync(join(work, "cache"))).toBe(false);
}, 120_000);
