/**
 * A hostile or broken physical robot cannot take the twin down through its relay (issue 34): a relay,
 * follow or register target that is the twin itself, or a physical TD whose stop form is, is refused at
 * start; a stop form that reaches the twin through another name ends in 508 instead of a loop; an
 * endless answer costs at most the size cap; a stop during a relayed move the robot never answers makes
 * the move answer `stopped`; a move action without output is an answer; credentials in a URL are sent,
 * never shown. Real servients and backends, a proxy in front of the physical one (`peer-proxy.ts`).
 */
import { afterAll, beforeAll, expect, it } from "vitest";
import { startServient, type RunningServient } from "../packages/servient/src/index.js";
import { endless, hang, peerProxy, type PeerProxy } from "./helpers/peer-proxy.js";
import { generateTwin, http, invoke, kukaPose, onFreePort, waitFor } from "./serve-helpers.js";

const AUTH = { scheme: "basic" as const, user: "robot", password: "s3cret-pw" };

let kuka: string;
let physical: RunningServient;
const started: RunningServient[] = [];
const proxies: PeerProxy[] = [];

beforeAll(async () => {
  kuka = await generateTwin("kuka_iiwa", 3000);
  // the physical Thing behind basic auth
  physical = await startServient({ twins: [kuka], port: 0, realtime: 0, auth: AUTH });
});
afterAll(async () => {
  for (const s of started) await s.stop();
  for (const p of proxies) await p.close();
  await physical?.stop();
});

async function twin(opts: Partial<Parameters<typeof startServient>[0]>): Promise<{ s: RunningServient; base: string }> {
  const s = await startServient({ twins: [kuka], port: 0, realtime: 0, ...opts });
  started.push(s);
  return { s, base: `${s.url}/${s.things[0]!.slug}` };
}

async function proxy(route?: Parameters<typeof peerProxy>[1]): Promise<PeerProxy> {
  const p = await peerProxy(physical.url, route);
  proxies.push(p);
  return p;
}

/** The physical TD URL with the credentials in it, through `p`. */
const withUser = (p: PeerProxy): string => `${p.url.replace("http://", `http://${AUTH.user}:${AUTH.password}@`)}/${physical.things[0]!.slug}`;

/** `startServient` on a free port, expected to be refused: the port and the refusal. */
async function refusedOnFreePort(options: (port: number) => Parameters<typeof startServient>[0]): Promise<{ port: number; error?: Error }> {
  const { port, value, error } = await onFreePort((port) => startServient(options(port)));
  if (value) started.push(value);
  return { port, ...(error ? { error } : {}) };
}

it.each(["relay", "follow", "register"] as const)("--%s pointing at the twin itself is refused at start", async (option) => {
  const { port, error } = await refusedOnFreePort((port) => ({ twins: [kuka], port, realtime: 0, [option]: `http://localhost:${port}/lbr-iiwa` }));
  expect(error?.message).toContain(`--${option} http://localhost:${port}/lbr-iiwa is this servient itself`);
});

it("a physical TD whose stop form points at the twin is refused at start", async () => {
  let stopAt = "";
  const p = await proxy((req) => (req.method === "GET" && !req.url!.includes("/properties/") ? { td: (td) => ({ ...td, actions: { ...td.actions, stop: { ...td.actions.stop, forms: [{ href: stopAt }] } } }) } : "forward"));
  const { port, error } = await refusedOnFreePort((port) => {
    stopAt = `http://127.0.0.1:${port}/lbr-iiwa/actions/stop`;
    return { twins: [kuka], port, realtime: 0, relay: withUser(p), follow: false };
  });
  expect(error?.message).toContain(`--relay: the form of actions/stop at http://127.0.0.1:${port}/lbr-iiwa/actions/stop is this servient itself`);
});

it("a stop form that reaches the twin under another name answers 508: one stop, a bounded number of requests", async () => {
  // a second proxy forwards to the twin; the physical TD's stop form points at that proxy
  let twinUrl = "";
  const toTwin = await peerProxy("http://127.0.0.1:9", () => (req, res, body) => {
    const u = new URL(twinUrl);
    void fetch(`${u.origin}${req.url}`, { method: req.method, headers: req.headers as Record<string, string>, ...(body.length ? { body } : {}) }).then(async (a) => {
      res.writeHead(a.status, { "Content-Type": a.headers.get("content-type") ?? "application/json" }).end(Buffer.from(await a.arrayBuffer()));
    }, () => res.destroy());
  });
  proxies.push(toTwin);
  const p = await proxy((req) => (req.method === "GET" && !req.url!.includes("/properties/") ? { td: (td) => ({ ...td, actions: { ...td.actions, stop: { ...td.actions.stop, forms: [{ href: `${toTwin.url}/lbr-iiwa/actions/stop` }] } } }) } : "forward"));
  const { s, base } = await twin({ relay: withUser(p), follow: false });
  twinUrl = s.url;
  const stop = await invoke(base, "stop", "");
  expect(stop.status).toBe(200);
  expect(stop.body.physical.ok).toBe(false);
  expect(stop.body.physical.error).toMatch(/Loop Detected/);
  // the stops that reached the twin came back from it as 508 and relayed nothing more
  const looped = toTwin.count(/actions\/stop/);
  expect(looped).toBeGreaterThan(0);
  expect(looped).toBeLessThanOrEqual(stop.body.physical.attempts);
  expect((await http(`${base}/properties/motionStatus`)).status).toBe(200);
});

it("an endless answer to a relayed move is cut at the size cap: the move's relay fails, memory stays bounded", async () => {
  const p = await proxy((req) => (req.method === "POST" && /moveTo/.test(req.url!) ? endless : "forward"));
  const { base } = await twin({ relay: withUser(p), follow: false });
  const before = process.memoryUsage().rss;
  const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([0.2, 0, 0, -0.5, 0, 0.3, 0]) });
  expect(r.status).toBe(200);
  expect(r.body.relay.ok).toBe(false);
  expect(r.body.relay.error).toMatch(/answer larger than 1048576 bytes/);
  expect(process.memoryUsage().rss - before).toBeLessThan(50 * 1024 * 1024);
});

it("a stop during a relayed move the physical robot never answers: the move answers stopped", async () => {
  const p = await proxy((req) => (req.method === "POST" && /moveTo/.test(req.url!) ? hang : "forward"));
  const { base } = await twin({ relay: withUser(p), follow: false });
  const move = invoke(base, "moveToJointPosition", { joints: kukaPose([-0.2, 0, 0, -0.5, 0, 0.3, 0]) });
  await waitFor(() => p.count(/POST .*moveTo/) > 0, { what: "the relayed move at the proxy" });
  const stop = await invoke(base, "stop", "");
  expect(stop.body).toMatchObject({ stopped: true, physical: { ok: true } });
  const r = await move;
  expect(r.status).toBe(200);
  expect(r.body.status).toBe("stopped");
  expect((await http(`${base}/properties/motionStatus`)).body.state).toBe("stopped");
});

it("a physical move action declaring no output is answered, not stopped; credentials are sent, never shown", async () => {
  const p = await proxy((req) =>
    req.method === "GET" && !req.url!.includes("/properties/")
      ? { td: (td) => ({ ...td, actions: { ...td.actions, moveToJointPosition: { ...td.actions.moveToJointPosition, output: undefined } } }) }
      : "forward",
  );
  const { s, base } = await twin({ relay: withUser(p) });
  // what the serve banner prints: the peers without their credentials
  expect(s.peers).toEqual({ relay: `${p.url}/${physical.things[0]!.slug}`, follow: `${p.url}/${physical.things[0]!.slug}` });
  const r = await invoke(base, "moveToJointPosition", { joints: kukaPose([0.3, 0.1, 0, -0.6, 0, 0.3, 0]) });
  expect(r.body.status).toBe("reached");
  expect(r.body.relay.ok).toBe(true);
  expect(p.count(/actions\/stop/)).toBe(0);
  // followed through the same URL: the readings pass the physical Thing's basic auth
  const state = await waitFor(async () => {
    const v = (await http(`${base}/properties/physicalState`)).body;
    return v.joints ? v : null;
  }, { what: "a reading through the proxy" });
  const shown = JSON.stringify([state, r.body, (await http(`${base}/properties/motionStatus`)).body]);
  expect(shown).not.toContain(AUTH.password);
  expect(state.source).toBe(`${p.url}/${physical.things[0]!.slug}`);
});
