#!/usr/bin/env node
// `npm run ship:parts`: the convex parts of the bundled robots' collision meshes, written into
// sim-backend/src/robwot_sim/data/collision (SHIPPED_PARTS in decompose.py), so a robot's first use
// does not decompose them. Each bundled robot is loaded by a backend with an empty collision cache (its
// missing parts are decomposed there; parts already shipped are found) and exported; the folders the
// exports hold are, together, the new shipped set, which replaces the old one. Run it after a change of
// the decomposition's parameters or of a bundled mesh; tests/shipped-parts.test.ts fails until then.
import { cpSync, mkdtempSync, readdirSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { launchBackend } from "@robwot/sim-client";
import { EXAMPLE_ROBOTS, exampleUrdfPath } from "../packages/cli/dist/examples.js";

const root = join(dirname(fileURLToPath(import.meta.url)), "..");
const shipped = join(root, "sim-backend/src/robwot_sim/data/collision");
const work = mkdtempSync(join(tmpdir(), "robwot-ship-parts-"));
const next = join(work, "collision");
const backend = await launchBackend({ env: { ROBWOT_COLLISION_CACHE: join(work, "cache") } });
try {
  const { pybulletData } = await backend.client.ping();
  for (const robot of EXAMPLE_ROBOTS) {
    const t0 = performance.now();
    const model = await backend.client.loadRobot({ urdf: exampleUrdfPath(robot, pybulletData), id: robot.name });
    const out = join(work, "export", robot.name);
    await backend.client.exportRobot({ robot: model.id, outDir: out });
    const parts = join(out, "collision");
    const folders = readdirSync(out).includes("collision") ? readdirSync(parts) : [];
    for (const f of folders) cpSync(join(parts, f), join(next, f), { recursive: true });
    console.log(`${robot.name.padEnd(14)} ${String(folders.length).padStart(3)} mesh folders  ${((performance.now() - t0) / 1000).toFixed(1)} s`);
  }
} finally {
  await backend.stop();
}
rmSync(shipped, { recursive: true, force: true });
cpSync(next, shipped, { recursive: true });
rmSync(work, { recursive: true, force: true });
console.log(`wrote ${readdirSync(shipped).length} mesh folders to ${shipped}`);
