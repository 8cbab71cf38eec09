// Benchmark of @robwot/core workspace queries (run after `npx tsc -b packages/core`):
//   node packages/core/scripts/bench-workspace.mjs
// Prints build and query times for point-in-mesh, distance to surface and point-cloud kNN.
import { PointCloudIndex, WorkspaceMesh, writeStl } from "../dist/index.js";
import { ballPoints, icosphere, rng } from "../dist/test-support/shapes.js";

const ms = (t0) => (performance.now() - t0).toFixed(1);
const rows = [];
for (const sub of [5, 6]) {
  const tri = icosphere(sub, 1);
  const stl = writeStl(tri);
  let t0 = performance.now();
  const mesh = WorkspaceMesh.fromStl(stl);
  const build = ms(t0);
  const r = rng(1);
  const pts = Array.from({ length: 10000 }, () => [0, 1, 2].map(() => (2 * r() - 1) * 1.2));
  t0 = performance.now();
  let inside = 0;
  for (const p of pts) inside += mesh.contains(p) ? 1 : 0;
  const contains = ms(t0);
  t0 = performance.now();
  for (const p of pts) mesh.distanceToSurface(p);
  const dist = ms(t0);
  rows.push({ what: `mesh ${mesh.triangleCount} triangles`, build_ms: build, "10k contains ms": contains, "10k distance ms (incl. grid)": dist, inside });
}
for (const n of [80000]) {
  const points = ballPoints(n, 1, rng(2));
  const free = new Uint8Array(n).map((_, i) => (points[3 * i] > 0.3 ? 0 : 1));
  let t0 = performance.now();
  const idx = new PointCloudIndex(points, free);
  const build = ms(t0);
  const r = rng(3);
  t0 = performance.now();
  for (let i = 0; i < 10000; i++) idx.score([0, 1, 2].map(() => (2 * r() - 1) * 1.2), 10);
  rows.push({ what: `cloud ${n} points`, build_ms: build, "10k score(k=10) ms": ms(t0) });
}
console.table(rows);
