/**
 * A coupled robot in a real browser (Debian's headless Chromium): the Dobot-like parallel-linkage fixture
 * generated with `--keep-level link_4`, moved by a node-wot consumer. The page offers sliders for the
 * leaders only and places every link where the linkage does: its end-effector link sits where the
 * twin's forward kinematics (followers applied by the backend) puts it.
 */
import { existsSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { invoke, openSession, read, type Session, type Twin } from "@robwot/consumers";
import { startServient } from "@robwot/servient";
import { runCli } from "./cli-run.js";
import { CHROMIUM, openBrowser, type BrowserSession } from "./helpers/browser.js";

const ROOT = resolve(import.meta.dirname, "..");
type Joints = Record<string, number>;
type Xyz = { x: number; y: number; z: number };
type Debug = { phase: string; ee: Xyz | null; joints: Joints; framesApplied: number; liveConnected: boolean; errors: string[] };

describe.skipIf(process.env["ROBWOT_SKIP_BROWSER"] === "1")("a coupled robot in the viewer", () => {
  let dir: string;
  let servient: Awaited<ReturnType<typeof startServient>>;
  let browser: BrowserSession;
  let session: Session;
  let twin: Twin;
  let page: string;
  const debug = (): Promise<Debug> => browser.page.evaluate(() => (window as unknown as { __robwot: Debug }).__robwot);

  beforeAll(async () => {
    if (!existsSync(CHROMIUM)) throw new Error(`no Chromium at ${CHROMIUM}: apt-get install chromium (ROBWOT_SKIP_BROWSER=1 skips)`);
    dir = mkdtempSync(join(tmpdir(), "robwot-viewer-couplings-"));
    const out = join(dir, "dobot");
    const generated = await runCli(["generate", join(ROOT, "examples/robots/dobot_like.urdf"), "--keep-level", "link_4", "--samples", "2000", "--out", out]);
    expect(generated.code, generated.stderr).toBe(0);
    servient = await startServient({ twins: [out], port: 0, host: "127.0.0.1" });
    const base = servient.url.endsWith("/") ? servient.url : `${servient.url}/`;
    const slug = servient.things[0]?.slug ?? "";
    page = `${base}viewer/?thing=${encodeURIComponent(slug)}`;
    session = await openSession();
    twin = await session.connect(`${base}${slug}`);
    browser = await openBrowser();
  }, 120_000);

  afterAll(async () => {
    await browser?.close();
    await session?.close();
    await servient?.stop();
    if (dir) rmSync(dir, { recursive: true, force: true });
  });

  it("shows sliders for the leaders only and draws the end where the twin's kinematics puts it", async () => {
    const target = { joint_1: 0.4, joint_2: 0.9, joint_3: 0.6, joint_5: -0.3 };
    await invoke(twin, "moveToJointPosition", { joints: target, speed: 1 });
    await browser.page.goto(page);
    await browser.page.waitForFunction(() => {
      const d = (window as unknown as { __robwot: Debug }).__robwot;
      return d.phase !== "loading" && d.liveConnected && d.framesApplied > 0;
    }, null, { timeout: 30_000 });
    const d = await debug();
    expect(d.phase).toBe("ready");
    expect(d.errors).toEqual([]);
    expect(Object.keys(d.joints).sort()).toEqual(Object.keys(target).sort()); // the follower joint_4 is no input
    for (const [name, value] of Object.entries(target)) expect(d.joints[name]).toBeCloseTo(value, 6);
    await expect(browser.page.locator('input[type="range"][data-joint="joint_4"]').count()).resolves.toBe(0);
    const pose = await read<Xyz>(twin, "getCartesianPosition");
    const ee = d.ee as Xyz;
    expect(Math.hypot(ee.x - pose.x, ee.y - pose.y, ee.z - pose.z)).toBeLessThan(1e-4);
  }, 60_000);
});
