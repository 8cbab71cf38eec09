/**
 * The program panel's plots in a real browser: `robwot generate` -> servient (in-process, port 0) -> the
 * viewer in Debian's headless Chromium (playwright-core). A program of joint steps validated through the
 * panel is plotted (joint positions and velocities, TCP speed over time); what the plots show equals the
 * validateProgram answer a node-wot consumer gets for the same steps; a refused program is plotted up to
 * its refused step. The world's objects are plotted over time from /live scene messages; a twin relaying to
 * `robwot emulate` (the physical robot, lagging) plots the divergence the servient reports. Screenshots go to
 * test-artifacts/ and, with ROBWOT_UPDATE_SCREENSHOTS=1, the viewer README's into packages/viewer/docs/.
 */
import { cpSync, existsSync, mkdirSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { invoke, openSession, read, type Session, type Twin } from "@robwot/consumers";
import { startEmulator, startServient } from "@robwot/servient";
import { runCli } from "./cli-run.js";
import { http, invoke as post, live } from "./serve-helpers.js";
import { CHROMIUM, openBrowser, pixelStats, type BrowserSession } from "./helpers/browser.js";
import { waitFor } from "./helpers/wait.js";
import type { DivergenceHistory } from "../packages/viewer/src/divergence-plot.js";

const ROOT = resolve(import.meta.dirname, "..");
const ARTIFACTS = join(ROOT, "test-artifacts");
/** The README's screenshots are taken again only on request (ROBWOT_UPDATE_SCREENSHOTS=1): a test run leaves the tree as it found it. */
const DOCS = process.env["ROBWOT_UPDATE_SCREENSHOTS"] === "1" ? join(ROOT, "packages/viewer/docs") : null;

type Joints = Record<string, number>;
interface Plots {
  rate: number;
  samples: number;
  timeSpan: number;
  joints: string[];
  units: string[];
  positions: Record<string, number[]>;
  maxVelocity: Record<string, number>;
  maxTcpSpeed: number | null;
}
interface Debug {
  phase: string;
  liveConnected: boolean;
  framesApplied: number;
  errors: string[];
  program: { valid: boolean; cycleTime: number; plots: Plots | null } | null;
  objectHistory: { samples: number; timeSpan: number; objects: Record<string, ([number, number, number] | null)[]> } | null;
  divergenceHistory: DivergenceHistory | null;
}
interface Report {
  valid: boolean;
  firstFailingStep?: number;
  steps: { ok: boolean; duration: number }[];
  cycleTime: number;
  trajectory: { rate: number; names: string[]; positions: number[][] };
}

const PAGE = { intervalMs: 100, ignoreErrors: true } as const;

describe.skipIf(process.env["ROBWOT_SKIP_BROWSER"] === "1")("viewer program plots in headless Chromium", () => {
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
    dir = mkdtempSync(join(tmpdir(), "robwot-plots-"));
    const out = join(dir, "kuka");
    const generated = await runCli(["generate", "kuka_iiwa", "--samples", "2000", "--out", out]);
    expect(generated.code, generated.stderr).toBe(0);
    servient = await startServient({ twins: [out], port: 0, host: "127.0.0.1" });
    base = servient.url.endsWith("/") ? servient.url : `${servient.url}/`;
    slug = servient.things[0]?.slug ?? "";
    session = await openSession();
    twin = await session.connect(`${base}${slug}`);
    browser = await openBrowser({ width: 1280, height: 1000 });
    mkdirSync(ARTIFACTS, { recursive: true });
    if (DOCS !== null) mkdirSync(DOCS, { recursive: true });
  });

  afterAll(async () => {
    await browser?.close();
    await session?.close();
    await servient?.stop();
    if (dir) rmSync(dir, { recursive: true, force: true });
  });

  it("plots a validated program's joint positions, velocities and TCP speed as validateProgram answers them", async () => {
    const { page, problems } = browser;
    await page.goto(`${base}viewer/?thing=${encodeURIComponent(slug)}`);
    await page.waitForFunction(() => {
      const d = (window as unknown as { __robwot: Debug }).__robwot;
      return d.phase !== "loading" && d.liveConnected && d.framesApplied > 0;
    });
    expect((await debug()).phase).toBe("ready");
    // a twin that follows no physical robot: no divergence panel
    expect((await debug()).divergenceHistory).toBeNull();
    expect(await page.locator("#divergence-plot").isHidden()).toBe(true);
    // the whole page as loaded (the view, the panels on top of the side bar) for the viewer README
    if (DOCS !== null) await page.screenshot({ path: join(DOCS, "viewer.png") });
    // three joint steps from where the robot stands: two joints out, a third, then back
    const home = await read<Joints>(twin, "getJointPosition");
    const [j1, j2, j4] = ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2", "lbr_iiwa_joint_4"].map((j) => home[j] ?? 0) as [number, number, number];
    const steps = [
      { joints: { ...home, lbr_iiwa_joint_1: j1 + 0.5, lbr_iiwa_joint_2: j2 + 0.3 } },
      { joints: { ...home, lbr_iiwa_joint_1: j1 + 0.5, lbr_iiwa_joint_2: j2 + 0.3, lbr_iiwa_joint_4: j4 - 0.4 }, speed: 0.5 },
      { joints: home },
    ];
    await page.locator("#program textarea").fill(JSON.stringify(steps));
    await page.locator("#program button", { hasText: "Validate" }).click();
    const plots = await waitFor(async () => (await debug()).program?.plots, { ...PAGE, what: "the program's plots" });
    const report = await invoke<Report>(twin, "validateProgram", { steps });
    expect(report.valid).toBe(true);
    expect((await debug()).program?.cycleTime).toBe(report.cycleTime);
    const { rate, names, positions } = report.trajectory;
    // the same samples over the same time span (the last sample where the program ends: its cycle time),
    // every joint's values those of the answer
    expect(plots.rate).toBe(rate);
    expect(plots.samples).toBe(positions.length);
    expect(plots.timeSpan).toBeCloseTo(report.cycleTime, 9);
    expect(plots.timeSpan).toBeGreaterThan((positions.length - 2) / rate);
    expect(plots.timeSpan).toBeLessThanOrEqual((positions.length - 1) / rate + 1e-9);
    expect(plots.joints).toEqual(names);
    expect(plots.units).toEqual(names.map(() => "rad"));
    names.forEach((n, j) => expect(plots.positions[n]).toEqual(positions.map((q) => q[j])));
    // the joints that move have a velocity, the others none; the TCP moves
    for (const moved of ["lbr_iiwa_joint_1", "lbr_iiwa_joint_2", "lbr_iiwa_joint_4"]) expect(plots.maxVelocity[moved]).toBeGreaterThan(0.01);
    expect(plots.maxVelocity["lbr_iiwa_joint_3"]).toBe(0);
    expect(plots.maxTcpSpeed).toBeGreaterThan(0.01);
    expect(plots.maxTcpSpeed).toBeLessThan(10);
    const panel = page.locator("#program");
    await panel.scrollIntoViewIfNeeded();
    const chart = await pixelStats(page, page.locator("#program canvas.plot").first());
    expect(chart.distinctColours).toBeGreaterThan(4);
    await panel.screenshot({ path: join(ARTIFACTS, "viewer-program-plots.png") });
    if (DOCS !== null) await panel.screenshot({ path: join(DOCS, "program-plots.png") });
    expect((await debug()).errors).toEqual([]);
    expect(problems).toEqual([]);
  });

  it("plots the world's objects over time from /live scene messages, as the objects property has them", async () => {
    const { page, problems } = browser;
    await page.goto(`${base}viewer/?thing=${encodeURIComponent(slug)}`);
    await page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.liveConnected);
    const cube = { name: "plotted", shape: { type: "box", size: [0.05, 0.05, 0.05] }, color: [0.9, 0.2, 0.1] };
    await invoke(twin, "addObject", { ...cube, position: [0.6, 0, 0.3] });
    for (const position of [[0.6, 0.3, 0.3], [0.3, 0.6, 0.3]]) await invoke(twin, "moveObject", { name: "plotted", position });
    const rested = (await read<{ name: string; position: number[] }[]>(twin, "objects")).find((o) => o.name === "plotted")!;
    const history = await waitFor(async () => {
      const h = (await debug()).objectHistory;
      const last = h?.objects["plotted"]?.at(-1);
      return last && Math.abs(last[0] - rested.position[0]!) < 1e-9 ? h : undefined;
    }, { ...PAGE, what: "the moved object in the objects plot" });
    // added, moved twice: each resting pose a sample, in order, each on the floor (z = half its size)
    const track = history.objects["plotted"]!.filter((p): p is [number, number, number] => p !== null);
    expect(track.length).toBeGreaterThanOrEqual(3);
    expect(track.map((p) => [Math.round(p[0] * 10) / 10, Math.round(p[1] * 10) / 10])).toEqual(expect.arrayContaining([[0.6, 0], [0.6, 0.3], [0.3, 0.6]]));
    for (const p of track) expect(p[2]).toBeCloseTo(0.025, 2);
    expect(track.at(-1)).toEqual(rested.position);
    const panel = page.locator("#objects-plot");
    await panel.scrollIntoViewIfNeeded();
    expect((await pixelStats(page, page.locator("#objects-plot canvas.plot").first())).distinctColours).toBeGreaterThan(3);
    await panel.screenshot({ path: join(ARTIFACTS, "viewer-objects-plot.png") });
    if (DOCS !== null) await panel.screenshot({ path: join(DOCS, "objects-plot.png") });
    await invoke(twin, "removeObject", { name: "plotted" });
    expect((await debug()).errors).toEqual([]);
    expect(problems).toEqual([]);
  });

  it("plots a refused program up to where the refused step starts", async () => {
    const { page } = browser;
    const home = await read<Joints>(twin, "getJointPosition");
    const tcp = await read<{ x: number; y: number; z: number }>(twin, "getCartesianPosition");
    // step 1: a LIN to 20 cm below the start's TCP at 3 m/s with the joints at 0.1 % of their velocity
    // limits, which no joint can keep up with: refused
    const steps = [
      { joints: { ...home, lbr_iiwa_joint_1: (home["lbr_iiwa_joint_1"] ?? 0) + 0.5, lbr_iiwa_joint_2: (home["lbr_iiwa_joint_2"] ?? 0) + 0.3 } },
      { motion: "lin", x: tcp.x, y: tcp.y, z: tcp.z - 0.2, tcpSpeed: 3, speed: 0.001 },
    ];
    await page.locator("#program textarea").fill(JSON.stringify(steps));
    await page.locator("#program button", { hasText: "Validate" }).click();
    const verdict = page.locator("#program .verdict");
    await waitFor(async () => ((await verdict.textContent()) ?? "").includes("refused at step 1"), { ...PAGE, what: "the refusal" });
    const drawn = (await debug()).program!;
    const report = await invoke<Report>(twin, "validateProgram", { steps });
    expect(report).toMatchObject({ valid: false, firstFailingStep: 1 });
    expect(drawn.plots?.samples).toBe(report.trajectory.positions.length);
    expect(drawn.plots?.timeSpan).toBeCloseTo(report.steps[0]?.duration ?? NaN, 9);
    expect(drawn.plots?.positions["lbr_iiwa_joint_1"]).toEqual(report.trajectory.positions.map((q) => q[0]));
  });

  it("plots a relayed move's divergence from the physical robot (robwot emulate, lagging) as the servient reports it", async () => {
    const { page, problems } = browser;
    // the physical robot: an emulated one whose reported joints lag 0.5 s; a twin relaying to it (and so
    // following it) at 50 readings a second, its simulation at once, the robot after it. The emulator, the
    // servient and the browser share this process and a test machine's cores: the monitor's horizon is 1 s
    // (a reading late by the default 0.2 s plus a period under a loaded run made it blind, and it stopped
    // the robot as it must); the plots are what this test is about
    const robot = await startEmulator({ folder: join(dir, "kuka"), port: 0, lag: 0.5 });
    const folder = join(dir, "kuka-relayed");
    cpSync(join(dir, "kuka"), folder, { recursive: true });
    const relaying = await startServient({ twins: [folder], port: 0, host: "127.0.0.1", realtime: 0, relay: robot.tdUrl, followRate: 50, horizon: 1 });
    const thing = relaying.things[0]!;
    const stream = await live(`${relaying.liveUrl}?thing=${thing.slug}`);
    try {
      await page.goto(`${relaying.url.endsWith("/") ? relaying.url : `${relaying.url}/`}viewer/?thing=${encodeURIComponent(thing.slug)}`);
      // followed: the panel is shown at once, empty until a move is relayed
      await page.waitForFunction(() => (window as unknown as { __robwot: Debug }).__robwot.divergenceHistory !== null);
      expect(await page.locator("#divergence-plot").isVisible()).toBe(true);
      expect((await debug()).divergenceHistory?.samples).toBe(0);
      // joint 1 by 1 rad at 5 % of 10 rad/s (0.5 rad/s, 4 time constants): a divergence near 0.5 x 0.5 rad;
      // joint 2 leaning the arm out so that the TCP diverges too
      const home = (await http(`${thing.tdUrl}/properties/getJointPosition`)).body as Joints;
      const target = { ...home, lbr_iiwa_joint_1: (home["lbr_iiwa_joint_1"] ?? 0) - 1, lbr_iiwa_joint_2: (home["lbr_iiwa_joint_2"] ?? 0) + 0.5 };
      const r = await post(thing.tdUrl, "moveToJointPosition", { joints: target, speed: 0.05 });
      expect(r.body.relay?.ok, JSON.stringify(r.body)).toBe(true);
      const state = (await http(`${thing.tdUrl}/properties/physicalState`)).body as { maxDivergence: { joint: number; tcp: number; bound: number } };
      const event = await stream.waitFor((m) => m.type === "divergence");
      // the relayed command has ended: its largest divergence as the servient reports it, then a gap
      const h = await waitFor(
        async () => {
          const d = (await debug()).divergenceHistory;
          return d?.max?.joint === state.maxDivergence.joint && d.joint.at(-1) === null ? d : undefined;
        },
        { ...PAGE, what: "the relayed move's divergence in the plot" },
      );
      expect(h.max).toEqual({ joint: state.maxDivergence.joint, tcp: state.maxDivergence.tcp });
      expect(h.bound).toBe(state.maxDivergence.bound);
      // every reading plotted is one the servient pushed on /live, with its divergence (rad, m) unchanged
      const pushed = new Map<string, { joint: number; tcp: number }>();
      for (const m of stream.messages) if (m.type === "physical" && m.divergence && m.timestamp) pushed.set(m.timestamp, m.divergence);
      const plotted = h.timestamps.flatMap((t, i) => (h.joint[i] === null ? [] : [{ t, joint: h.joint[i]!, tcp: h.tcp[i]! }]));
      expect(plotted.length).toBeGreaterThan(20);
      const matched = plotted.filter((p) => pushed.has(p.t));
      expect(matched.length).toBeGreaterThan(0.8 * plotted.length);
      for (const p of matched) expect({ joint: p.joint, tcp: p.tcp }).toEqual(pushed.get(p.t));
      // over the relayed motion's time, times increasing, the largest close to the servient's (a reading
      // may be coalesced away on a slow socket, never one made up)
      expect(h.times).toEqual([...h.times].sort((a, b) => a - b));
      expect(h.timeSpan).toBeGreaterThan(0.5 * r.body.duration);
      expect(h.timeSpan).toBeLessThan(r.body.duration + 3);
      const largest = Math.max(...plotted.map((p) => p.joint));
      expect(largest).toBeLessThanOrEqual(state.maxDivergence.joint);
      expect(largest).toBeGreaterThan(0.9 * state.maxDivergence.joint);
      expect(largest).toBeGreaterThan(0.15);
      expect(Math.max(...plotted.map((p) => p.tcp))).toBeGreaterThan(0.01);
      // the divergence event: once, marked at the reading that raised it, with its per-joint differences
      expect(h.events).toHaveLength(1);
      const [marked] = h.events;
      expect(marked).toMatchObject({ joint: event.joint, tcp: event.tcp, bound: event.bound, time: event.time });
      expect(marked!.bound).toBe(state.maxDivergence.bound);
      expect(marked!.at).toBe(h.times[h.joint.indexOf(event.joint)]);
      expect(marked!.differences["lbr_iiwa_joint_1"]).toBeCloseTo(event.joints.lbr_iiwa_joint_1 - event.expected.lbr_iiwa_joint_1, 12);
      const panel = page.locator("#divergence-plot");
      await panel.scrollIntoViewIfNeeded();
      expect((await pixelStats(page, page.locator("#divergence-plot canvas.plot").first())).distinctColours).toBeGreaterThan(3);
      await panel.screenshot({ path: join(ARTIFACTS, "viewer-divergence-plot.png") });
      if (DOCS !== null) await panel.screenshot({ path: join(DOCS, "divergence-plot.png") });
      expect((await debug()).errors).toEqual([]);
      expect(problems).toEqual([]);
    } finally {
      stream.close();
      await relaying.stop();
      await robot.stop();
    }
  });
});
