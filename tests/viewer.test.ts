/**
 * End to end in a real browser: `robwot generate` -> servient (in-process, port 0) -> the viewer page in
 * Debian's headless Chromium (playwright-core). Checks the page loads without console errors, draws a
 * non-blank scene, that a slider moves the twin, that a motion started by a node-wot consumer moves the
 * model in the page, the Cartesian form's validate-then-move flow and Stop; saves screenshots under
 * test-artifacts/.
 */
import { spawn } from "node:child_process";
import { cpSync, existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { invoke, openSession, read, type Session, type Twin } from "@robwot/consumers";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { startEmulator, startServient } from "@robwot/servient";
import { CHROMIUM, openBrowser, pixelStats, type BrowserSession } from "./helpers/browser.js";
import { waitFor } from "./helpers/wait.js";

const ROOT = resolve(import.meta.dirname, "..");
const CLI = join(ROOT, "packages/cli/dist/main.js");
const ARTIFACTS = join(ROOT, "test-artifacts");
const J1 = "lbr_iiwa_joint_1";
const SCENE = {
  version: 1,
  name: "viewer-test",
  obstacles: [{ name: "block", shape: { type: "box", size: [0.2, 0.2, 0.3] }, position: [-0.5, 0.5, 0.15], rpy: [0, 0, 0.4] }],
  robots: [{ id: "kuka", urdf: "kuka_iiwa/model.urdf", basePosition: [0.4, -0.3, 0.05], baseOrientation: [0, 0, Math.sin(Math.PI / 8), Math.cos(Math.PI / 8)] }],
};

type Joints = Record<string, number>;
type Xyz = { x: number; y: number; z: number };
type Debug = {
  phase: string;
  ee: Xyz | null;
  target: { position: [number, number, number]; valid: boolean | null } | null;
  joints: Joints;
  framesApplied: number;
  liveConnected: boolean;
  liveMessages: number;
  pointCloud: { shown: number; total: number; collisionFree: number } | null;
  workspaceTriangles: number;
  reachability: { voxels: number; shown: number; maxIndex: number; visible: boolean } | null;
  obstacles: string[];
  objects: Record<string, number[]>;
  otherRobots: Record<string, { base: number[]; joints: Joints }>;
  errors: string[];
  twins: string[];
  lastStatus: { state?: string } | null;
  collisions: number;
  highlighted: string[];
  physical: { joints: Joints; age: number | null; drawn: boolean; ghost: boolean } | null;
};

function run(cmd: string, args: string[]): Promise<string> {
  return new Promise((ok, fail) => {
    const child = spawn(cmd, args, { stdio: ["ignore", "pipe", "pipe"] });
    let out = "";
    child.stdout.on("data", (d: Buffer) => (out += d.toString()));
    child.stderr.on("data", (d: Buffer) => (out += d.toString()));
    child.on("error", fail);
    child.on("exit", (code) => (code === 0 ? ok(out) : fail(new Error(`${cmd} ${args.join(" ")} exited ${code}:\n${out}`))));
  });
}

/** waits on the page: a probe that throws (the page between two loads) counts as "not yet" */
const PAGE = { intervalMs: 100, ignoreErrors: true } as const;

const dist = (a: Xyz, b: Xyz): number => Math.hypot(a.x - b.x, a.y - b.y, a.z - b.z);
const maxDiff = (a: Joints, b: Joints): number => Math.max(...Object.keys(a).map((k) => Math.abs((a[k] ?? NaN) - (b[k] ?? NaN))));

// Opt out explicitly (ROBWOT_SKIP_BROWSER=1); a missing browser otherwise fails loudly instead of skipping.
describe.skipIf(process.env["ROBWOT_SKIP_BROWSER"] === "1")("viewer in headless Chromium", () => {
  let dir: string;
  let servient: Awaited<ReturnType<typeof startServient>>;
  let base: string;
  let slug: string;
  let browser: BrowserSession;
  let session: Session;
  let twin: Twin;
  const debug = (): Promise<Debug> => browser.page.evaluate(() => (window as unknown as { __robwot: Debug }).__robwot);

  beforeAll(async () => {
    if (!existsSync(CHROMIUM)) {
      throw new Error(`no Chromium at ${CHROMIUM}: apt-get install chromium, or set ROBWOT_CHROMIUM (ROBWOT_SKIP_BROWSER=1 skips)`);
    }
    if (!existsSync(join(ROOT, "packages/viewer/dist/viewer.js"))) {
      throw new Error("packages/viewer/dist is missing: run `npm run build` (it bundles the viewer) first");
    }
    dir = mkdtempSync(join(tmpdir(), "robwot-viewer-"));
    const out = join(dir, "kuka");
    // The robot stands off the origin, turned 45 degrees, next to one obstacle: the page must place it.
    const scene = join(dir, "scene.json");
    writeFileSync(scene, JSON.stringify(SCENE));
    await run(process.execPath, [CLI, "generate", "kuka_iiwa", "--scene", scene, "--samples", "3000", "--out", out]);
    servient = await startServient({ twins: [out], port: 0, host: "127.0.0.1" });
    base = servient.url.endsWith("/") ? servient.url : `${servient.url}/`;
    slug = servient.things[0]?.slug ?? "";
    session = await openSession();
    twin = await session.connect(`${base}${slug}`);
    browser = await openBrowser();
    mkdirSync(ARTIFACTS, { recursive: true });
  });

  afterAll(async () => {
    await browser?.close();
    await session?.close();
    await servient?.stop();
    if (dir) rmSync(dir, { recursive: true, force: true });
  });

  it("lists the served twins at /viewer/", async () => {
    await browser.page.goto(`${base}viewer/`);
    await browser.page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.phase === "list");
    expect((await debug()).twins).toEqual([slug]);
    await expect(browser.page.locator(`a[href="/viewer/?thing=${slug}"]`).count()).resolves.toBe(1);
  });

  it("loads the twin without console errors and draws the robot, point cloud and workspace", async () => {
    const { page, problems } = browser;
    problems.length = 0;
    await page.goto(`${base}viewer/?thing=${encodeURIComponent(slug)}`);
    await page.waitForFunction(() => {
      const d = (window as unknown as { __robwot: Debug }).__robwot;
      return d.phase !== "loading" && d.liveConnected && d.framesApplied > 0;
    }, null, { timeout: 30_000 });
    const d = await debug();
    expect(d.phase).toBe("ready");
    expect(d.errors).toEqual([]);
    expect(problems).toEqual([]);
    expect(d.pointCloud?.total).toBe(3000);
    expect(d.pointCloud?.collisionFree).toBeGreaterThan(0);
    expect(d.workspaceTriangles).toBeGreaterThan(10);
    expect(d.obstacles).toEqual(["block"]);
    // the reachability heat map: every voxel of the file read, those reached collision-free drawn, hidden
    // until its layer is switched on
    const mapRows = readFileSync(join(dir, "kuka", "reachability.csv"), "utf8").trim().split("\n").slice(1);
    expect(d.reachability).toMatchObject({ voxels: mapRows.length, visible: false });
    expect(d.reachability?.shown).toBe(mapRows.filter((r) => Number(r.split(",")[4]) > 0).length);
    expect(d.reachability?.maxIndex).toBe(Math.max(...mapRows.map((r) => Number(r.split(",")[6]))));
    const before = await pixelStats(page, page.locator("#view canvas"), join(ARTIFACTS, "viewer-no-heat.png"));
    await page.getByLabel(/^reachability map \(\d+ voxels\)$/).check();
    await page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.reachability?.visible === true);
    const heat = await pixelStats(page, page.locator("#view canvas"), join(ARTIFACTS, "viewer-heat-map.png"));
    expect(heat.distinctColours).toBeGreaterThan(before.distinctColours);
    await page.getByLabel(/^reachability map/).uncheck();
    const state = await read<Joints>(twin, "getJointPosition");
    expect(maxDiff(state, d.joints)).toBeLessThan(1e-6);
    // Frames, base pose and joint application agree with the simulation: the displayed model's
    // end-effector link sits where the twin's forward kinematics puts it.
    const pose = await read<Xyz>(twin, "getCartesianPosition");
    expect(dist(d.ee as Xyz, pose)).toBeLessThan(1e-4);
    // Not blank: many colours, real variance, a good share of the canvas covered by the scene.
    const stats = await pixelStats(page, page.locator("#view canvas"), join(ARTIFACTS, "viewer-canvas.png"));
    expect(stats.width).toBeGreaterThan(300);
    expect(stats.distinctColours).toBeGreaterThan(40);
    expect(stats.stdDev).toBeGreaterThan(8);
    expect(stats.nonBackground).toBeGreaterThan(0.05);
    await page.screenshot({ path: join(ARTIFACTS, "viewer.png") });
  });

  it("obstacles added, moved and removed through the servient appear in the page (live scene)", async () => {
    const { problems } = browser;
    problems.length = 0;
    const crate = { name: "crate", shape: { type: "box", size: [0.1, 0.1, 0.1] }, position: [-0.9, -1.1, 0.05] };
    await invoke(twin, "addObstacle", crate);
    try {
      await waitFor(async () => {
        const names = (await debug()).obstacles;
        return names.length === 2 && names.includes("block") && names.includes("crate");
      }, { ...PAGE, what: "the page to draw the added obstacle" });
      await invoke(twin, "moveObstacle", { name: "crate", position: [-0.9, -1.2, 0.05] });
      await invoke(twin, "addObstacle", { name: "ball", shape: { type: "sphere", radius: 0.05 }, position: [-1.0, -1.0, 0.05] });
      await waitFor(async () => (await debug()).obstacles.includes("ball"), { ...PAGE, what: "the page to draw the second one" });
      expect((await debug()).obstacles).toEqual(["block", "crate", "ball"]);
    } finally {
      // clean-up: the obstacles may already be gone when the test failed early
      await invoke(twin, "removeObstacle", { name: "crate" }).catch(() => undefined);
      await invoke(twin, "removeObstacle", { name: "ball" }).catch(() => undefined);
    }
    await waitFor(async () => JSON.stringify((await debug()).obstacles) === '["block"]', { ...PAGE, what: "the page to drop the removed obstacles" });
    const d = await debug();
    expect(d.errors).toEqual([]);
    expect(problems).toEqual([]);
  });

  it("objects are drawn where they rest and follow moveObject (live scene)", async () => {
    const { problems } = browser;
    problems.length = 0;
    // let go above the block (top 0.3 m): it rests on it; moved beside it: it rests on the floor
    await invoke(twin, "addObject", { name: "mug", shape: { type: "cylinder", radius: 0.04, length: 0.1 }, position: [-0.5, 0.5, 0.6], color: [0.9, 0.2, 0.2] });
    try {
      await waitFor(async () => (await debug()).objects["mug"] !== undefined, { ...PAGE, what: "the page to draw the object" });
      expect((await debug()).objects["mug"]![2]).toBeCloseTo(0.35, 2);
      await invoke(twin, "moveObject", { name: "mug", position: [-0.9, -1.0, 0.3] });
      await waitFor(async () => ((await debug()).objects["mug"]?.[2] ?? 1) < 0.1, { ...PAGE, what: "the page to draw the object on the floor" });
      expect((await debug()).objects["mug"]![2]).toBeCloseTo(0.05, 2);
    } finally {
      await invoke(twin, "removeObject", { name: "mug" }).catch(() => undefined);
    }
    await waitFor(async () => Object.keys((await debug()).objects).length === 0, { ...PAGE, what: "the page to drop the removed object" });
    expect((await debug()).errors).toEqual([]);
    expect(problems).toEqual([]);
  });

  it("moving a joint slider moves the twin on the servient", async () => {
    const before = await read<Joints>(twin, "getJointPosition");
    const target = (before[J1] ?? 0) > 0.3 ? -0.4 : 0.6;
    await browser.page.locator(`input[data-joint="${J1}"]`).fill(String(target));
    const after = await waitFor(async () => {
      const q = await read<Joints>(twin, "getJointPosition");
      return Math.abs((q[J1] ?? NaN) - target) < 1e-3 ? q : null;
    }, { ...PAGE, what: "joint 1 to reach the slider value" });
    for (const [k, v] of Object.entries(before)) if (k !== J1) expect(after[k]).toBeCloseTo(v, 3);
    // The page shows the state the servient streamed.
    await waitFor(async () => Math.abs(((await debug()).joints[J1] ?? NaN) - target) < 1e-3, { ...PAGE, what: "the page model to follow" });
    expect(browser.problems).toEqual([]);
  });

  it("a new slider target while the twin moves replaces the old one (newest wins)", async () => {
    const { page } = browser;
    // the speed slider spans what the TD's move actions accept (the contract's range)
    const speedInput = (await (await fetch(`${base}${slug}`)).json()).actions.moveToJointPosition.input.properties.speed;
    expect(speedInput).toMatchObject({ minimum: VALUE_SCHEMAS.Speed.minimum, maximum: VALUE_SCHEMAS.Speed.maximum });
    const range = await page.locator("#motion input[name=speed]").evaluate((e) => [(e as HTMLInputElement).min, (e as HTMLInputElement).max]);
    expect(range.map(Number)).toEqual([speedInput.minimum, speedInput.maximum]);
    await page.locator("#motion input[name=speed]").fill("0.05");
    const slider = page.locator(`input[data-joint="${J1}"]`);
    await slider.fill("1.2");
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state === "moving", { ...PAGE, what: "the first slider motion to start" });
    await slider.fill("-0.3");
    const q = await waitFor(async () => {
      const status = await read<{ state: string }>(twin, "motionStatus");
      const j = await read<Joints>(twin, "getJointPosition");
      return status.state !== "moving" && Math.abs((j[J1] ?? NaN) + 0.3) < 1e-3 ? j : null;
    }, { ...PAGE, what: "joint 1 to settle on the newest target" });
    expect(q[J1]).toBeCloseTo(-0.3, 3);
    expect((await debug()).errors).toEqual([]);
    await page.locator("#motion input[name=speed]").fill("0.5");
  });

  it("a motion started by a node-wot consumer moves the model in the page", async () => {
    const start = await debug();
    const q = await read<Joints>(twin, "getJointPosition");
    const J4 = "lbr_iiwa_joint_4";
    const target: Joints = { ...q, lbr_iiwa_joint_2: 0.5, [J4]: -1.0, lbr_iiwa_joint_6: 0.6 };
    // A slow motion (~2 s at 5 % of the velocity limits); meanwhile record what the page displays.
    const motion = invoke<{ status: string; joints: Joints; position: Xyz }>(twin, "moveToJointPosition", { joints: target, speed: 0.05 });
    let done = false;
    motion.finally(() => (done = true)).catch(() => undefined);
    const shown: number[] = [];
    while (!done) {
      shown.push((await debug()).joints[J4] ?? NaN);
      // the sampling period of what the page shows (no time is asserted)
      await new Promise((r) => setTimeout(r, 50));
    }
    const result = await motion;
    expect(result.status).toBe("reached");
    const seen = await waitFor(async () => {
      const d = await debug();
      return maxDiff(target, d.joints) < 1e-3 ? d : null;
    }, { ...PAGE, what: "the page model to reach the consumer's target" });
    // The live stream moved the model through intermediate states, not just to the end pose.
    const from = q[J4] ?? NaN;
    expect(shown.some((v) => Math.min(v - -1.0, from - v) > 0.05)).toBe(true);
    expect(seen.framesApplied).toBeGreaterThan(start.framesApplied + 1);
    expect(dist(seen.ee as Xyz, result.position)).toBeLessThan(1e-4);
    expect(seen.liveMessages).toBeGreaterThan(start.liveMessages);
    await browser.page.screenshot({ path: join(ARTIFACTS, "viewer-after-consumer-move.png") });
  });

  it("validates a Cartesian target before enabling Move, then moves there", async () => {
    const { page } = browser;
    const pose = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
    const target = { x: pose.x, y: pose.y, z: pose.z - 0.05 };
    for (const axis of ["x", "y", "z"] as const) await page.locator(`#cartesian input[name=${axis}]`).fill(target[axis].toFixed(3));
    const move = page.locator("#cartesian button", { hasText: "Move" });
    await expect(move.isDisabled()).resolves.toBe(true);
    await page.locator("#cartesian button", { hasText: "Validate" }).click();
    const verdict = page.locator("#cartesian .verdict");
    await verdict.waitFor({ state: "visible" });
    const text = await verdict.textContent();
    const report = await invoke<{ valid: boolean }>(twin, "validateCartesianPosition", {
      x: Number(target.x.toFixed(3)),
      y: Number(target.y.toFixed(3)),
      z: Number(target.z.toFixed(3)),
    });
    expect(text?.startsWith(report.valid ? "✔ valid" : "✘ rejected")).toBe(true);
    await expect(move.isDisabled()).resolves.toBe(!report.valid);
    // The target is marked in the view with the same verdict (no calibration: world frame = input).
    const marked = (await debug()).target;
    expect(marked?.valid).toBe(report.valid);
    expect(marked?.position[2]).toBeCloseTo(Number(target.z.toFixed(3)), 6);
    expect(report.valid).toBe(true); // 5 cm below a collision-free pose of the kuka, in the free workspace
    await move.click();
    await waitFor(async () => {
      const p = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
      return Math.hypot(p.x - target.x, p.y - target.y, p.z - target.z) < 0.005;
    }, { ...PAGE, what: "the end effector to reach the Cartesian target" });
  });

  it("LIN from the panel: the straight line is validated and moved along (planned=lin)", async () => {
    const { page } = browser;
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state !== "moving", { ...PAGE, what: "the twin to be idle" });
    const pose = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
    const target = { x: pose.x, y: pose.y + 0.05, z: pose.z };
    for (const axis of ["x", "y", "z"] as const) await page.locator(`#cartesian input[name=${axis}]`).fill(target[axis].toFixed(3));
    await page.locator("#cartesian select[name=motion]").selectOption("lin");
    await page.locator("#cartesian button", { hasText: "Validate" }).click();
    const verdict = page.locator("#cartesian .verdict");
    await waitFor(async () => ((await verdict.textContent()) ?? "").includes("planned=lin"), { ...PAGE, what: "the LIN verdict" });
    expect((await verdict.textContent())?.startsWith("✔ valid")).toBe(true);
    await page.locator("#cartesian button", { hasText: "Move" }).click();
    await waitFor(async () => {
      const p = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
      return Math.hypot(p.x - target.x, p.y - target.y, p.z - target.z) < 0.005;
    }, { ...PAGE, what: "the end effector to reach the LIN target" });
    await page.locator("#cartesian select[name=motion]").selectOption("ptp");
  });

  it("a program: validated, its TCP path drawn per step, a refused step drawn red, played, then run on the twin", async () => {
    const { page } = browser;
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state !== "moving", { ...PAGE, what: "the twin to be idle" });
    await page.locator("#program button", { hasText: "Example" }).click();
    const steps = JSON.parse(await page.locator("#program textarea").inputValue());
    expect(steps).toHaveLength(5);
    await page.locator("#program button", { hasText: "Validate" }).click();
    const verdict = page.locator("#program .verdict");
    await waitFor(async () => ((await verdict.textContent()) ?? "").includes("cycle time"), { ...PAGE, what: "the program's verdict" });
    expect((await verdict.textContent())?.startsWith("✔ valid")).toBe(true);
    const drawn = await page.evaluate(() => window.__robwot.program);
    expect(drawn?.valid).toBe(true);
    expect(drawn?.failing).toBeNull();
    expect(drawn?.points).toHaveLength(5);
    // the square's four LINs drawn with several TCP samples each
    for (const n of drawn!.points.slice(0, 4)) expect(n).toBeGreaterThan(5);
    await page.locator("#program button", { hasText: "Play" }).click();
    await waitFor(async () => ((await page.evaluate(() => window.__robwot.program?.played)) ?? 0) >= 1, { ...PAGE, what: "the path played", timeoutMs: 30_000 });
    // step 1 a LIN at 3 m/s with the joints at 0.1 % of their velocity limits: refused (no joint can keep
    // that speed), drawn red from the end of step 0 to its target
    const far = [steps[0], { ...steps[1], speed: 0.001, tcpSpeed: 3 }];
    await page.locator("#program textarea").fill(JSON.stringify(far));
    await page.locator("#program button", { hasText: "Validate" }).click();
    await waitFor(async () => ((await verdict.textContent()) ?? "").includes("refused at step 1"), { ...PAGE, what: "the refusal" });
    const refused = await page.evaluate(() => window.__robwot.program);
    expect(refused).toMatchObject({ valid: false, failing: 1 });
    expect(refused?.points).toHaveLength(1);
    // run the valid program: the twin ends back at its joints
    const before = await read<Record<string, number>>(twin, "getJointPosition");
    await page.locator("#program textarea").fill(JSON.stringify(steps));
    await page.locator("#program button", { hasText: "Run" }).click();
    await waitFor(async () => ((await verdict.textContent()) ?? "").startsWith("run: reached"), { ...PAGE, what: "the run's answer", timeoutMs: 60_000 });
    const after = await read<Record<string, number>>(twin, "getJointPosition");
    for (const [j, v] of Object.entries(before)) expect(after[j]).toBeCloseTo(v, 4);
  });

  it("the Stop button stops a running motion", async () => {
    // the previous test's move may still be answering (its pose was reached first): a move now would be 409
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state !== "moving", { ...PAGE, what: "the twin to be idle" });
    const q = await read<Joints>(twin, "getJointPosition");
    // Turning the last (wrist) joint is collision-free whatever the rest of the arm does.
    const J7 = "lbr_iiwa_joint_7";
    const target: Joints = { ...q, [J7]: (q[J7] ?? 0) > 0 ? -2.5 : 2.5 };
    const motion = invoke<{ status: string }>(twin, "moveToJointPosition", { joints: target, speed: 0.05 });
    motion.catch(() => undefined); // awaited below; keep an early rejection from being "unhandled"
    // Click once the page shows the wrist actually turning (the motion is running in the simulation).
    await waitFor(async () => Math.abs(((await debug()).joints[J7] ?? NaN) - (q[J7] ?? NaN)) > 0.05, { ...PAGE, what: "the page to show the motion" });
    await browser.page.locator("#motion button.stop").click();
    await expect(motion).resolves.toMatchObject({ status: "stopped" });
    const stoppedAt = await read<Joints>(twin, "getJointPosition");
    expect(Math.abs((stoppedAt[J7] ?? NaN) - (target[J7] ?? NaN))).toBeGreaterThan(0.05);
    await waitFor(async () => (await debug()).lastStatus?.state === "stopped", { ...PAGE, what: "the page status to say stopped" });
  });

  it("a rejected target lists what its path touches and draws those bodies red", async () => {
    const { page } = browser;
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state !== "moving", { ...PAGE, what: "the twin to be idle" });
    const pose = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
    // a block around a target 10 cm below the end effector: every IK solution reaching it collides there
    const target = { x: pose.x, y: pose.y, z: pose.z - 0.1 };
    await invoke(twin, "addObstacle", { name: "wall", shape: { type: "box", size: [0.2, 0.2, 0.2] }, position: [target.x, target.y, target.z] });
    try {
      for (const axis of ["x", "y", "z"] as const) await page.locator(`#cartesian input[name=${axis}]`).fill(target[axis].toFixed(3));
      const report = await invoke<{ valid: boolean; checks: { path?: { contacts: { a: { body: string }; b: { body: string } }[] } } }>(twin, "validateCartesianPosition", {
        x: Number(target.x.toFixed(3)),
        y: Number(target.y.toFixed(3)),
        z: Number(target.z.toFixed(3)),
      });
      const contacts = report.checks.path?.contacts ?? [];
      await page.locator("#cartesian button", { hasText: "Validate" }).click();
      const seen = await waitFor(async () => {
        const d = await debug();
        return d.target?.valid === false && d.highlighted.length > 0 ? d : null;
      }, { ...PAGE, what: "the page to show the touching bodies" });
      expect(report.valid).toBe(false);
      expect(contacts.length).toBeGreaterThan(0);
      expect(seen.highlighted).toContain("wall");
      const text = (await page.locator("#cartesian .verdict").textContent()) ?? "";
      expect(text).toMatch(/touching: .*wall/);
    } finally {
      await invoke(twin, "removeObstacle", { name: "wall" });
    }
  });

  it("a collision event highlights the colliding link in the page", async () => {
    const q = await read<Joints>(twin, "getJointPosition");
    const a: Joints = { ...q, [J1]: 0.8, lbr_iiwa_joint_2: 0.6, lbr_iiwa_joint_4: -1.0 };
    const b: Joints = { ...a, [J1]: -0.8 };
    await invoke(twin, "moveToJointPosition", { joints: a, speed: 1 });
    const p = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
    await invoke(twin, "moveToJointPosition", { joints: b, speed: 1 });
    const before = (await debug()).collisions;
    // Start a slow motion back to `a`, then put an obstacle where the end effector will be: the path was
    // validated before the obstacle existed, so the motion runs into it and stops on contact.
    const motion = invoke<{ status: string }>(twin, "moveToJointPosition", { joints: a, speed: 0.05 });
    motion.catch(() => undefined); // awaited below
    await waitFor(async () => (await read<{ state: string }>(twin, "motionStatus")).state === "moving", { ...PAGE, what: "the motion to start" });
    await invoke(twin, "addObstacle", { name: "probe", shape: { type: "sphere", radius: 0.06 }, position: [p.x, p.y, p.z] });
    try {
      await expect(motion).resolves.toMatchObject({ status: "collision" });
      const seen = await waitFor(async () => {
        const d = await debug();
        return d.collisions > before && d.highlighted.length > 0 ? d : null;
      }, { ...PAGE, what: "the page to highlight the collision" });
      expect(seen.highlighted).toContain("probe");
      expect(seen.highlighted.some((n) => n.startsWith("lbr_iiwa_link"))).toBe(true);
      await browser.page.screenshot({ path: join(ARTIFACTS, "viewer-collision.png") });
    } finally {
      await invoke(twin, "removeObstacle", { name: "probe" });
    }
  });

  describe("two twins in one world", () => {
    let shared: Awaited<ReturnType<typeof startServient>>;
    let sharedBase: string;
    let slugs: string[];
    beforeAll(async () => {
      // Two copies of the generated twin, the second one standing 2 m away along +y.
      const a = join(dir, "kuka-a");
      const b = join(dir, "kuka-b");
      cpSync(join(dir, "kuka"), a, { recursive: true });
      cpSync(join(dir, "kuka"), b, { recursive: true });
      const manifest = JSON.parse(readFileSync(join(b, "twin.json"), "utf8"));
      manifest.robot.basePosition = [0.4, 1.7, 0.05];
      manifest.robot.baseOrientation = [0, 0, 0, 1];
      writeFileSync(join(b, "twin.json"), JSON.stringify(manifest));
      shared = await startServient({ twins: [a, b], port: 0, host: "127.0.0.1" });
      sharedBase = `${shared.url}/`;
      slugs = shared.things.map((t) => t.slug);
    });
    afterAll(async () => shared?.stop());

    it("draws the other twin's robot at its base pose and moves it with its live joints", async () => {
      const { page, problems } = browser;
      const [mine, other] = slugs as [string, string];
      problems.length = 0;
      await page.goto(`${sharedBase}viewer/?thing=${encodeURIComponent(mine)}`);
      const drawn = await waitFor(async () => {
        const d = await debug();
        return d.phase === "ready" && d.otherRobots[other] && Object.keys(d.otherRobots[other].joints).length === 7 ? d : null;
      }, { ...PAGE, what: "the other robot to be drawn" });
      expect(Object.keys(drawn.otherRobots)).toEqual([other]);
      expect(drawn.otherRobots[other]?.base).toEqual([0.4, 1.7, 0.05]);
      const otherSession = await openSession();
      try {
        const otherTwin = await otherSession.connect(`${sharedBase}${other}`);
        const q = await read<Joints>(otherTwin, "getJointPosition");
        const target: Joints = { ...q, [J1]: (q[J1] ?? 0) > 0.3 ? -0.5 : 0.7, lbr_iiwa_joint_4: -0.8 };
        const result = await invoke<{ status: string }>(otherTwin, "moveToJointPosition", { joints: target, speed: 1 });
        expect(result.status).toBe("reached");
        await waitFor(async () => maxDiff(target, (await debug()).otherRobots[other]?.joints ?? {}) < 1e-3, { ...PAGE, what: "the page to show the other robot's new joints" });
      } finally {
        await otherSession.close();
      }
      // This twin's own model did not take the other robot's joints.
      const mineNow = await read<Joints>(await session.connect(`${sharedBase}${mine}`), "getJointPosition");
      expect(maxDiff(mineNow, (await debug()).joints)).toBeLessThan(1e-6);
      expect((await debug()).errors).toEqual([]);
      expect(problems).toEqual([]);
      await page.screenshot({ path: join(ARTIFACTS, "viewer-two-robots.png") });
    });
  });

  describe("a twin following its physical robot", () => {
    let robot: Awaited<ReturnType<typeof startEmulator>>;
    let following: Awaited<ReturnType<typeof startServient>>;
    beforeAll(async () => {
      const copy = join(dir, "kuka-followed");
      cpSync(join(dir, "kuka"), copy, { recursive: true });
      robot = await startEmulator({ folder: join(dir, "kuka"), port: 0 });
      following = await startServient({ twins: [copy], port: 0, host: "127.0.0.1", relay: robot.tdUrl, monitor: "off" });
    });
    afterAll(async () => {
      await following?.stop();
      await robot?.stop();
    });

    it("draws the real robot with its joints and the simulated one as a ghost", async () => {
      const { page, problems } = browser;
      // the page of an earlier test may still retry its stopped servient's /live: leave it first
      await page.goto("about:blank");
      problems.length = 0;
      const mine = following.things[0]!.slug;
      await page.goto(`${following.url}/viewer/?thing=${encodeURIComponent(mine)}`);
      await waitFor(async () => {
        const d = await debug();
        return d.phase === "ready" && d.physical?.drawn && d.physical.ghost;
      }, { ...PAGE, what: "the physical robot to be drawn" });
      // a pendant jog of the real robot: the page's real robot follows it
      const jog = await fetch(`${robot.tdUrl}/actions/jog`, {
        method: "POST",
        headers: { "content-type": "application/json" },
        body: JSON.stringify({ velocities: { [J1]: 0.5 }, duration: 0.6 }),
      });
      expect(jog.status).toBe(200);
      const real = (await (await fetch(`${robot.tdUrl}/properties/getJointPosition`)).json()) as Joints;
      await waitFor(async () => maxDiff(real, (await debug()).physical?.joints ?? {}) < 1e-6, { ...PAGE, what: "the page to show the real robot's joints" });
      expect((await debug()).errors).toEqual([]);
      expect(problems).toEqual([]);
      await page.screenshot({ path: join(ARTIFACTS, "viewer-physical-robot.png") });
    });

    it("a twin that follows nothing draws no second robot", async () => {
      await browser.page.goto(`${base}viewer/?thing=${encodeURIComponent(slug)}`);
      await waitFor(async () => (await debug()).phase === "ready", { ...PAGE, what: "the page" });
      // the marker: a scene edit made now reaches the page after everything the twin sent it before
      await invoke(twin, "addObstacle", { name: "marker", shape: { type: "sphere", radius: 0.01 }, position: [-1.5, -1.5, 0.05] });
      try {
        await waitFor(async () => (await debug()).obstacles.includes("marker"), { ...PAGE, what: "the page to draw the marker" });
      } finally {
        await invoke(twin, "removeObstacle", { name: "marker" });
      }
      expect((await debug()).physical).toBeNull();
    });
  });

  it("reports a missing mesh in the page and still shows the rest", async () => {
    const { page, problems } = browser;
    const folder = join(dir, "kuka");
    const urdf = readFileSync(join(folder, "robot.urdf"), "utf8");
    const mesh = /<visual>[\s\S]*?filename="([^"]+)"/.exec(urdf)?.[1];
    expect(mesh).toBeDefined();
    rmSync(join(folder, mesh as string));
    // leave the previous page first: its /live socket may still log a failed reconnect otherwise
    await page.goto("about:blank");
    problems.length = 0;
    await page.goto(`${base}viewer/?thing=${encodeURIComponent(slug)}`);
    await page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.phase !== "loading", null, { timeout: 30_000 });
    const d = await debug();
    expect(d.phase).toBe("ready");
    expect(d.errors.length).toBe(1);
    expect(d.errors[0]).toContain(mesh);
    await expect(page.locator("#errors .error").first().textContent()).resolves.toContain("E_MESH");
    expect(problems.filter((p) => !p.includes(mesh as string))).toEqual([]);
  });

  it("shows errors in the page for an unknown twin", async () => {
    const { page, problems } = browser;
    problems.length = 0;
    await page.goto(`${base}viewer/?thing=no-such-twin`);
    await page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.phase === "error");
    await expect(page.locator("#errors .error").first().textContent()).resolves.toMatch(/no-such-twin/);
    // The failing request is the only problem (the browser logs the 404 itself).
    expect(problems.filter((p) => !p.includes("no-such-twin"))).toEqual([]);
  });
});
