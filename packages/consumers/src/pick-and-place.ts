/**
 * Scenario 2: a pick-and-place loop that validates every target before moving.
 *
 * For each Cartesian target (a pick and a place station on each side of the robot, each with an
 * approach point above it, one point deliberately out of reach, and, when the twin's scene has small
 * obstacles, a point on top of each and one inside it):
 *   1. OFFLINE: inside workspace.stl? and the point-cloud score from workspace.csv, both fetched once
 *      from the TD's links and evaluated locally with @robwot/core;
 *   2. the twin's validateCartesianPosition (STL, point cloud, IK, collision-free path in the scene);
 *   3. moveToCartesianPosition only if the twin says valid.
 * Prints a table of targets and verdicts. Targets are derived from the TD's Cartesian bounds, so the
 * loop fits any robot; `--targets "x,y,z;x,y,z"` gives your own (metres, the twin's frame).
 *
 *   node packages/consumers/dist/pick-and-place.js [TD URL] [--targets ...] [--speed 1] [--json]
 */
import { speedOption, parseArgs, stringOption, UsageError } from "./lib/args.js";
import { authHeaders, defaultTdUrl, invoke, openSession, read, type Twin } from "./lib/connect.js";
import { fmt, fmtXyz, printJsonSummary, table } from "./lib/format.js";
import { activeCalibration, invertCalibration, norm, sub, vec, xyz, type Vec3 } from "@robwot/core";
import { loadOfflineWorkspace, type OfflineVerdict } from "./lib/offline.js";
import { runScenario } from "./lib/run.js";
import { tableStations } from "./lib/targets.js";
import { cartesianBounds, TWIN_FILES, type Bounds3 } from "@robwot/core";
import type { CalibrationState, MoveOutput, ValidationReport } from "./lib/types.js";

const USAGE = "pick-and-place [TD URL] [--targets \"x,y,z;x,y,z\"] [--speed 0..1] [--json]";

interface Target {
  label: string;
  p: Vec3;
}

/**
 * Stations on a circle around the middle of the workspace, at 45% of its horizontal half-extent and 30%
 * of its height above the floor: pick at +90°, place at -90°, pick at 0°, place at 180°, each preceded by an
 * approach point 10 cm higher, then one point near the top corner of the bounding box (out of reach).
 */
/** The stations of `tableStations`, each with its approach point 10 cm above, and one point out of reach. */
export function defaultTargets(b: Bounds3): Target[] {
  const { stations, outOfReach } = tableStations(b);
  const out: Target[] = [];
  for (const { label, p } of stations) out.push({ label: `${label} approach`, p: [p[0], p[1], p[2] + 0.1] }, { label, p });
  out.push({ label: "out of reach", p: outOfReach });
  return out;
}

interface SceneObstacle {
  name?: string;
  shape?: { type?: string; size?: number[]; radius?: number; length?: number };
  position?: number[];
}

/** Half height and horizontal half extent of a primitive obstacle (undefined for meshes). */
function extents(o: SceneObstacle): { halfHeight: number; halfWidth: number } | undefined {
  const sh = o.shape;
  if (sh?.type === "box" && sh.size?.length === 3) return { halfHeight: (sh.size[2] as number) / 2, halfWidth: Math.max(sh.size[0] as number, sh.size[1] as number) / 2 };
  if (sh?.type === "cylinder" && sh.radius !== undefined && sh.length !== undefined) return { halfHeight: sh.length / 2, halfWidth: sh.radius };
  if (sh?.type === "sphere" && sh.radius !== undefined) return { halfHeight: sh.radius, halfWidth: sh.radius };
  return undefined;
}

/**
 * Targets from the scene (`<base>scene.json`, served next to the TD): for up to two small obstacles
 * (the table the robot stands on is skipped), "above <name>" 15 cm over its top (the approach for
 * placing a part there) and "into <name>" at its centre, which validation must refuse (collision).
 */
export function sceneTargets(obstacles: SceneObstacle[]): Target[] {
  const out: Target[] = [];
  for (const o of obstacles) {
    const e = extents(o);
    const p = o.position;
    if (e === undefined || p?.length !== 3 || e.halfWidth > 0.3 || out.length >= 4) continue;
    const [x, y, z] = p as Vec3;
    out.push({ label: `above ${o.name ?? "?"}`, p: [x, y, z + e.halfHeight + 0.15] }, { label: `into ${o.name ?? "?"}`, p: [x, y, z] });
  }
  return out;
}

async function fetchSceneObstacles(twin: Twin): Promise<SceneObstacle[]> {
  const url = new URL(TWIN_FILES.scene, twin.td.base ?? `${twin.url}/`).toString();
  // an unreachable file is reported below as "not available" (res undefined), not thrown
  const res = await fetch(url, { headers: authHeaders(twin.auth) }).catch(() => undefined);
  if (res === undefined || !res.ok) return [];
  const scene = (await res.json()) as { obstacles?: SceneObstacle[] };
  return scene.obstacles ?? [];
}

export function parseTargets(text: string): Target[] {
  return text.split(";").map((chunk, i) => {
    const v = chunk.split(",").map(Number);
    if (v.length !== 3 || !v.every(Number.isFinite)) throw new UsageError(`--targets entry ${i + 1} "${chunk}" is not x,y,z`);
    return { label: `target ${i + 1}`, p: v as Vec3 };
  });
}

const yesNo = (b: boolean | undefined): string => (b === undefined ? "-" : b ? "yes" : "no");

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), { targets: "value", speed: "value", json: "flag" });
  const url = args.positional[0] ?? defaultTdUrl();
  const speed = speedOption(args, 1);
  const session = await openSession();
  try {
    const twin = await session.connect(url);
    console.log(`Consumed "${twin.td.title ?? "?"}" from ${url}`);
    const given = stringOption(args, "targets");
    const targets =
      given !== undefined
        ? parseTargets(given)
        : [...defaultTargets(cartesianBounds(twin.td)), ...sceneTargets(await fetchSceneObstacles(twin))];

    const ws = await loadOfflineWorkspace(twin);
    console.log(`offline workspace: ${ws.triangles} triangles (${ws.stlUrl}), ${ws.points} points (${ws.csvUrl})`);
    // Targets are in the twin's Cartesian frame: the real frame when a calibration is active. The
    // workspace files are in the virtual frame, so map targets back for the offline check.
    const cal = await read<CalibrationState>(twin, "calibration");
    const active = activeCalibration(cal);
    const toVirtual = (p: Vec3): Vec3 => (active ? invertCalibration(active, p) : p);

    const rows: { label: string; target: Vec3; offline: OfflineVerdict; twin: ValidationReport; moved: MoveOutput | null }[] = [];
    for (const t of targets) {
      const offline = ws.check(toVirtual(t.p));
      const verdict = await invoke<ValidationReport>(twin, "validateCartesianPosition", xyz(t.p));
      let moved: MoveOutput | null = null;
      if (verdict.valid) moved = await invoke<MoveOutput>(twin, "moveToCartesianPosition", { ...xyz(t.p), speed });
      rows.push({ label: t.label, target: t.p, offline, twin: verdict, moved });
      const action = moved ? `moved: ${moved.status}, ${fmt(norm(sub(vec(moved.position), t.p)) * 1000, 2)} mm off` : `skipped: ${verdict.reasons.join("; ")}`;
      console.log(`${t.label.padEnd(16)} ${fmtXyz(xyz(t.p))}  ${action}`);
    }

    console.log(
      "\n" +
        table(
          ["target", "x, y, z (m)", "in STL", "cloud (share)", "offline", "twin STL", "twin cloud", "IK", "path", "twin", "agree", "result"],
          rows.map((r) => [
            r.label,
            fmtXyz(xyz(r.target), 3),
            yesNo(r.offline.inside),
            `${fmt(r.offline.pointCloud.nearestFree, 3)} m ${r.offline.pointCloud.ok ? "ok" : "no free sample near"}`,
            r.offline.ok ? "valid" : "invalid",
            yesNo(r.twin.checks.insideWorkspace?.ok),
            yesNo(r.twin.checks.pointCloud?.ok),
            yesNo(r.twin.checks.ik?.ok),
            yesNo(r.twin.checks.path?.ok),
            r.twin.valid ? "valid" : "invalid",
            yesNo(r.twin.checks.insideWorkspace === undefined || r.twin.checks.insideWorkspace.ok === r.offline.inside),
            r.moved ? r.moved.status : "not moved",
          ]),
        ),
    );
    const moved = rows.filter((r) => r.moved !== null).length;
    console.log(`\n${moved} of ${rows.length} targets moved to; offline and twin STL verdicts agree on ${rows.filter((r) => r.twin.checks.insideWorkspace?.ok === r.offline.inside).length}`);
    if (rows.some((r) => r.moved !== null && r.moved.status !== "reached")) process.exitCode = 1;
    if (args.options.has("json")) printJsonSummary({ rows });
  } finally {
    await session.close();
  }
}

runScenario("pick-and-place", USAGE, main);
