/**
 * A web page of another origin, opened in real headless Chromium, tries every way a browser lets a page
 * reach a local server: fetch (CORS), fetch no-cors with text/plain, a Blob POST, sendBeacon and a
 * WebSocket to /live. None moves the twin or reads its state; a page of the twin's own origin still
 * drives it. Neither can it frame the viewer (clickjacking its Move and STOP buttons); the twin's own
 * pages can. (The viewer's own controls are exercised by viewer.test.ts.)
 */
import { createServer, type Server } from "node:http";
import { existsSync } from "node:fs";
import type { AddressInfo } from "node:net";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { CHROMIUM, openBrowser, type BrowserSession } from "./helpers/browser.js";
import type { Request } from "playwright-core";
import { generateTwin, http, kukaPose, waitFor } from "./serve-helpers.js";

const FAR = kukaPose([0.6, 0.3, 0, -0.7, 0, 0.4, 0]);
let s: RunningServient;
let attacker: Server;
let attackerUrl: string;
let browser: BrowserSession;

beforeAll(async () => {
  s = await startServient({ twins: [await generateTwin("kuka_iiwa", 3000)], port: 0, realtime: 0 });
  attacker = createServer((_req, res) => {
    res.writeHead(200, { "content-type": "text/html" });
    res.end("<!doctype html><title>a page on the web</title>");
  });
  await new Promise<void>((r) => attacker.listen(0, "127.0.0.1", r));
  attackerUrl = `http://127.0.0.1:${(attacker.address() as AddressInfo).port}/`;
  browser = await openBrowser();
}, 300_000);
afterAll(async () => {
  await browser?.close();
  attacker?.close();
  await s?.stop();
});

const joints = async (): Promise<Record<string, number>> => (await http(`${s.things[0]!.tdUrl}/properties/getJointPosition`)).body;

describe.skipIf(!existsSync(CHROMIUM))("a page of another origin in Chromium", () => {
  it("cannot move the twin, stop it or watch it by any browser request", async () => {
    const { page } = browser;
    await page.goto(attackerUrl);
    const before = await joints();
    const target = `${s.things[0]!.tdUrl}/actions/moveToJointPosition`;
    const stop = `${s.things[0]!.tdUrl}/actions/stop`;
    const live = s.liveUrl;
    // every request the page makes to the servient, and which of them it has answered (or refused)
    const sent: Request[] = [];
    const settled = new Set<Request>();
    const onRequest = (r: Request): void => void (r.url().startsWith(s.url) && sent.push(r));
    const onSettled = (r: Request): void => void settled.add(r);
    page.on("request", onRequest);
    page.on("requestfinished", onSettled);
    page.on("requestfailed", onSettled);
    const outcome = await page.evaluate(
      async ({ target, stop, live, body }) => {
        const tries: Record<string, string> = {};
        const attempt = async (name: string, fn: () => Promise<unknown>): Promise<void> => {
          try {
            tries[name] = `sent: ${JSON.stringify(await fn())}`;
          } catch (e) {
            tries[name] = `failed: ${String(e)}`;
          }
        };
        await attempt("fetch cors json", async () => (await fetch(target, { method: "POST", headers: { "content-type": "application/json" }, body })).status);
        await attempt("fetch no-cors text/plain", async () => (await fetch(target, { method: "POST", mode: "no-cors", headers: { "content-type": "text/plain;charset=json" }, body })).type);
        await attempt("fetch no-cors blob", async () => (await fetch(target, { method: "POST", mode: "no-cors", body: new Blob([body]) })).type);
        await attempt("fetch no-cors stop", async () => (await fetch(stop, { method: "POST", mode: "no-cors" })).type);
        await attempt("sendBeacon string", async () => navigator.sendBeacon(target, body));
        await attempt("sendBeacon json blob", async () => navigator.sendBeacon(target, new Blob([body], { type: "application/json" })));
        await attempt("read joints", async () => (await fetch(target.replace(/actions\/.*/, "properties/getJointPosition"))).status);
        tries["websocket"] = await new Promise<string>((resolve) => {
          const ws = new WebSocket(live);
          const messages: string[] = [];
          ws.onopen = () => ws.send(JSON.stringify({ subscribe: "*" }));
          ws.onmessage = (m) => messages.push(String(m.data));
          ws.onerror = () => resolve(`error after ${messages.length} messages`);
          // bounds a failure only: the refusal closes the socket at once
          setTimeout(() => resolve(`open with ${messages.length} messages`), 30_000);
        });
        return tries;
      },
      { target, stop, live, body: JSON.stringify({ joints: FAR }) },
    );
    // beacons go out after sendBeacon returns: the absence below is judged once the servient has answered
    // every request the page made, both queued beacons included
    const beacons = Object.entries(outcome).filter(([name, r]) => name.startsWith("sendBeacon") && r === "sent: true").length;
    await waitFor(() => sent.filter((r) => r.resourceType() === "ping").length >= beacons && sent.every((r) => settled.has(r)), {
      what: "answers to every request the page sent",
    });
    page.off("request", onRequest);
    page.off("requestfinished", onSettled);
    page.off("requestfailed", onSettled);
    expect(outcome["fetch cors json"]).toMatch(/^failed/);
    expect(outcome["read joints"]).toMatch(/^failed/);
    expect(outcome["websocket"]).toBe("error after 0 messages");
    expect(await joints()).toEqual(before);
    expect((await http(`${s.things[0]!.tdUrl}/properties/motionStatus`)).body.state).toBe("idle");
  });

  it("a page of the twin's own origin drives it", async () => {
    const { page } = browser;
    await page.goto(`${s.url}/robwot.json`);
    const status = await page.evaluate(
      async ({ target, body }) => (await (await fetch(target, { method: "POST", headers: { "content-type": "application/json" }, body })).json()).status,
      { target: `${s.things[0]!.tdUrl}/actions/moveToJointPosition`, body: JSON.stringify({ joints: FAR }) },
    );
    expect(status).toBe("reached");
    expect((await joints()).lbr_iiwa_joint_1).toBeCloseTo(0.6, 6);
  });

  it("cannot frame the viewer (clickjacking), while a page of the twin's own origin can", async () => {
    const { page } = browser;
    const framed: Record<string, { url: string; title: string }> = {};
    for (const [who, at] of [["other", attackerUrl], ["own", `${s.url}/robwot.json`]] as const) {
      await page.goto(at);
      await page.evaluate(
        (src) =>
          new Promise<void>((loaded) => {
            const f = document.createElement("iframe");
            f.src = src;
            f.onload = () => loaded();
            document.body.appendChild(f);
          }),
        s.things[0]!.viewerUrl,
      );
      const frame = page.frames().find((f) => f !== page.mainFrame())!;
      framed[who] = { url: frame.url(), title: await frame.evaluate(() => document.title) };
    }
    expect(framed["other"]!.url).toMatch(/^chrome-error:/);
    expect(framed["other"]!.title).not.toMatch(/RobWoT/);
    // the viewer renames itself after the Thing once its script has run ("lbr_iiwa · RobWoT"); either
    // title proves the page loaded in the frame
    expect(framed["own"]!.url).toBe(s.things[0]!.viewerUrl);
    expect(framed["own"]!.title).toMatch(/RobWoT/);
  });
});
