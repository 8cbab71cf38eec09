/**
 * Headless Chromium (Debian's /usr/bin/chromium) driven by playwright-core, plus page checks shared by
 * the browser tests: console error capture and a pixel-variance check of a screenshot.
 */
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium, type BrowserContext, type Locator, type Page } from "playwright-core";

export const CHROMIUM = process.env["ROBWOT_CHROMIUM"] ?? "/usr/bin/chromium";

const ARGS = [
  "--no-sandbox",
  "--headless",
  "--disable-gpu",
  "--disable-quic",
  "--no-first-run",
  "--disable-background-networking",
  "--disable-component-update",
  "--disable-sync",
  // WebGL without a GPU: SwiftShader through ANGLE (Chromium no longer falls back to it on its own).
  "--use-angle=swiftshader",
  "--enable-unsafe-swiftshader",
];

export interface BrowserSession {
  context: BrowserContext;
  page: Page;
  /** Console errors, page errors and failed requests, in order. */
  problems: string[];
  close(): Promise<void>;
}

export async function openBrowser(viewport = { width: 1280, height: 800 }): Promise<BrowserSession> {
  const profile = mkdtempSync(join(tmpdir(), "robwot-chromium-"));
  const context = await chromium.launchPersistentContext(profile, {
    executablePath: CHROMIUM,
    headless: true,
    args: ARGS,
    viewport,
  });
  const page = context.pages()[0] ?? (await context.newPage());
  // Two shared cores and software WebGL: be patient (waits still end as soon as the condition holds).
  page.setDefaultTimeout(60_000);
  const problems: string[] = [];
  page.on("console", (msg) => {
    if (msg.type() === "error") problems.push(`console.error: ${msg.text()} (${msg.location().url})`);
  });
  page.on("pageerror", (err) => problems.push(`pageerror: ${err.message}`));
  page.on("requestfailed", (req) => problems.push(`request failed: ${req.url()} ${req.failure()?.errorText ?? ""}`));
  page.on("response", (res) => {
    if (res.status() >= 400) problems.push(`HTTP ${res.status()}: ${res.url()}`);
  });
  return {
    context,
    page,
    problems,
    close: async () => {
      await context.close();
      rmSync(profile, { recursive: true, force: true });
    },
  };
}

export interface PixelStats {
  width: number;
  height: number;
  /** Number of distinct colours (RGB quantised to 4 bits per channel). */
  distinctColours: number;
  /** Mean per-channel standard deviation, 0..255. */
  stdDev: number;
  /** Share of pixels far from the background colour (top-left pixel). */
  nonBackground: number;
}

/** Screenshot an element and measure its colour variance (decoded in the page: no PNG library needed). */
export async function pixelStats(page: Page, target: Locator, path?: string): Promise<PixelStats> {
  const png = await target.screenshot(path ? { path } : {});
  return page.evaluate(async (b64: string) => {
    const blob = await (await fetch(`data:image/png;base64,${b64}`)).blob();
    const bmp = await createImageBitmap(blob);
    const canvas = new OffscreenCanvas(bmp.width, bmp.height);
    const ctx = canvas.getContext("2d");
    if (!ctx) throw new Error("no 2d context");
    ctx.drawImage(bmp, 0, 0);
    const { data } = ctx.getImageData(0, 0, bmp.width, bmp.height);
    const n = bmp.width * bmp.height;
    const sum = [0, 0, 0];
    const sq = [0, 0, 0];
    const colours = new Set<number>();
    const bg = [data[0] ?? 0, data[1] ?? 0, data[2] ?? 0];
    let far = 0;
    for (let i = 0; i < n; i++) {
      let d = 0;
      for (let c = 0; c < 3; c++) {
        const v = data[i * 4 + c] ?? 0;
        sum[c]! += v;
        sq[c]! += v * v;
        d += Math.abs(v - bg[c]!);
      }
      if (d > 60) far++;
      colours.add((((data[i * 4] ?? 0) >> 4) << 8) | (((data[i * 4 + 1] ?? 0) >> 4) << 4) | ((data[i * 4 + 2] ?? 0) >> 4));
    }
    let sd = 0;
    for (let c = 0; c < 3; c++) sd += Math.sqrt(sq[c]! / n - (sum[c]! / n) ** 2) / 3;
    return { width: bmp.width, height: bmp.height, distinctColours: colours.size, stdDev: sd, nonBackground: far / n };
  }, png.toString("base64"));
}
