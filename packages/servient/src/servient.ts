/**
 * `startServient`: loads the twin folders, starts (or connects to) the simulation backend, builds the
 * shared world, exposes one node-wot Thing per twin over HTTP (with RobWoT's middleware), the `/live`
 * WebSocket on the same port, and the relay when asked.
 */
import { createRequire } from "node:module";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { existsSync } from "node:fs";
import { createServer } from "node:net";
import { MAX_SLUG_LENGTH, reachOverlaps, targetBounds, TWIN_FILES } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import type { AuthConfig } from "./auth.js";
import { BackendSupervisor, launchConnector, urlConnector } from "@robwot/sim-client";
import { fromBackendError, servientError } from "./errors.js";
import { createMiddleware, type ServedThing } from "./http-middleware.js";
import { attachLive, type LiveServer } from "./live.js";
import { exposeTwin, type ExposeEnv, type ExposedTwin } from "./expose-twin.js";
import { exposeCell, type ExposedCell } from "./cell-things.js";
import { exposeDevice, prepareDevice, type AsDeviceSpec, type PreparedDevice } from "./as-device.js";
import { boundedHttpClientFactory, LoopError, Outbound, OUTBOUND_LIMITS } from "./outbound.js";
import { MAX_FRAME_BYTES, ScanSource, type ScanSourceOptions } from "./scan-source.js";
import { Relay } from "./relay.js";
import { DIRECTORY_SEGMENTS } from "./directory.js";
import { Registrar } from "./register.js";
import type { MonitorMode } from "./follow.js";
import { loadRelayMap, type RelayMap } from "./relay-map.js";
import { defaultViewerDir } from "./static-files.js";
import { RequestGuard } from "./request-guard.js";
import { loadTwinFolder } from "./twin-folder.js";
import { Twin } from "./twin.js";
import { loadWorkspaceChecks, type WorkspaceChecks } from "./workspace-checks.js";
import { SceneRecord } from "./scene-record.js";

const require = createRequire(import.meta.url);
// node-wot 0.9.2 is CommonJS
const { Servient } = require("@node-wot/core") as typeof import("@node-wot/core");
const { HttpServer } = require("@node-wot/binding-http") as typeof import("@node-wot/binding-http");
const slugify = require("slugify") as (s: string, o: { lower: boolean }) => string;

export interface ServientOptions {
  /** twin folders (Contract 2) */
  twins: string[];
  host?: string;
  /** 0 = pick a free port */
  port?: number;
  /** real-time factor of motions: 1 = wall clock, 0 = as fast as possible */
  realtime?: number;
  /** TD URL of the physical robot's Thing */
  relay?: string;
  /** TD URL of the physical robot the twin mirrors (`physicalState`; the twin follows it when it moves
   *  without a twin command). Default: the `relay` Thing when one twin is served (a twin that commands a
   *  robot also watches it); `false`: no mirroring */
  follow?: string | false;
  /** readings of the physical robot per second (`FOLLOW_RATE`) */
  followRate?: number;
  /** rad or m: the joint divergence from a relayed motion that emits the `divergence` event (`DIVERGENCE_BOUND`) */
  divergenceBound?: number;
  /** a JSON file naming the physical Thing's own affordances, joint order and units (`--relay-map`,
   *  `relay-map.ts`), checked against the twin's joints at start */
  relayMap?: string;
  /** base URL of a Thing Description Directory to register the served TDs into (`register.ts`) */
  register?: string;
  /** the safety monitor on the followed robot: stop it (default), only warn, or off */
  monitor?: MonitorMode;
  /** s the monitor looks ahead beyond the lag it measures: the robot's unmeasured reporting lag and its
   *  time to act on a stop; unseen this long (plus a poll period) is a monitor fault (`MONITOR_HORIZON`) */
  horizon?: number;
  auth?: AuthConfig;
  /** ws:// URL of an already running backend (default: launch one) */
  backendUrl?: string;
  /** Python interpreter for the launched backend */
  python?: string;
  /** viewer bundle (default packages/viewer/dist) */
  viewerDir?: string;
  /** browser origins (e.g. a dashboard's `https://dash.example:3000`) granted CORS and allowed to send commands */
  corsOrigins?: string[];
  /** extra names accepted in the `Host` header (e.g. the machine's DNS name when bound to 0.0.0.0) */
  allowedHosts?: string[];
  /** folders (besides the twin folders) that run-time mesh obstacles (`addObstacle`) may come from */
  meshRoots?: string[];
  /** `--as DEVICE=TD [--as-map MAP]` (each): a twin also served as that physical device, at `/<name>`,
   *  with the device's own TD (`as-device.ts`); the files checked at start (`AsDeviceError`) */
  as?: AsDeviceSpec[];
  /** `--scan-source`: the scene kept current from a sensor's clouds (`scan-source.ts`) */
  scanSource?: ScanSourceOptions;
}

/** A device the twin answers as (`--as`). */
export interface DeviceInfo {
  name: string;
  id: string;
  title: string;
  tdUrl: string;
  /** the slug of the twin behind it */
  twin: string;
}

export interface ThingInfo {
  slug: string;
  id: string;
  title: string;
  tdUrl: string;
  viewerUrl: string;
}

export interface RunningServient {
  url: string;
  liveUrl: string;
  things: ThingInfo[];
  /** the backend supervisor (pid, restarts, isUp) */
  backend: BackendSupervisor;
  twins: Map<string, Twin>;
  /** the Things it relays to, follows and registers at (URLs without credentials) */
  peers: { relay?: string; follow?: string; register?: string };
  /** the devices the twin answers as (`--as`) */
  devices: DeviceInfo[];
  /** where the scene is kept current from (`--scan-source`; a URL without credentials) */
  scan?: string;
  stop(): Promise<void>;
}

/** URL path segments of the servient's own routes: no twin or device is served there. */
const RESERVED_SEGMENTS = ["viewer", "live", "robwot.json", ...DIRECTORY_SEGMENTS];

const isLoopback = (h: string): boolean => h === "127.0.0.1" || h === "localhost" || h === "::1" || h.startsWith("127.");

/** The options checked before anything starts; the realtime factor the backend will take. */
function checkOptions(opts: ServientOptions, host: string): number {
  if (opts.twins.length === 0) throw new Error("startServient: no twin folder given");
  const realtime = opts.realtime ?? 1;
  // a factor the backend refuses would make every move answer 400 for the server's own option
  const factor = VALUE_SCHEMAS.RealtimeFactor;
  if (!(realtime === 0 || (realtime >= factor.minimum && realtime <= factor.maximum))) throw new Error(`realtime must be 0 (as fast as possible) or in [${factor.minimum}, ${factor.maximum}], got ${realtime}`);
  if (opts.follow && opts.twins.length !== 1) throw new Error(`--follow mirrors one physical robot into one twin; ${opts.twins.length} twin folders given`);
  if (!isLoopback(host) && !opts.auth) {
    process.emitWarning(`robwot serve: binding ${host} without --auth exposes the robot to the network`, { code: "ROBWOT_NO_AUTH" });
  }
  return realtime;
}

/** Each twin by its URL path segment (its title, slugified; never one of the servient's own routes), with
 *  one id per Thing (node-wot needs them distinct: the same robot in the same scene has the same id). */
function nameTwins(opts: ServientOptions, backend: BackendSupervisor): Map<string, Twin> {
  const twins = new Map<string, Twin>();
  const slugs = new Set<string>(RESERVED_SEGMENTS);
  const ids = new Set<string>();
  for (const folder of opts.twins.map((t) => loadTwinFolder(t, opts.meshRoots ?? []))) {
    const base = slugify(folder.td.title, { lower: true });
    let slug = base;
    for (let n = 2; slugs.has(slug); n++) slug = `${base}_${n}`;
    if (slug.length > MAX_SLUG_LENGTH) {
      throw servientError("E_TWIN_FOLDER", `${join(folder.dir, TWIN_FILES.td)}: the title gives the URL path segment "${slug.slice(0, 40)}..." of ${slug.length} characters; at most ${MAX_SLUG_LENGTH} can be served (shorten the title)`, { folder: folder.dir, file: TWIN_FILES.td, field: "title" });
    }
    slugs.add(slug);
    if (folder.td.id && ids.has(folder.td.id)) folder.td.id = `${folder.td.id}:${slug}`;
    if (folder.td.id) ids.add(folder.td.id);
    twins.set(slug, new Twin(slug, folder, backend));
  }
  // twins of one world that can touch each other: said once, at start (each is an obstacle to the other)
  const placed = [...twins.entries()].map(([slug, t]) => {
    const p = t.folder.manifest.robot.basePosition ?? [0, 0, 0];
    return { name: `twin ${slug}`, base: [p[0] ?? 0, p[1] ?? 0, p[2] ?? 0] as [number, number, number], reach: targetBounds(t.folder.workspace) };
  });
  for (const w of reachOverlaps(placed)) process.emitWarning(`robwot serve: ${w}`, { code: "ROBWOT_TWINS_OVERLAP" });
  return twins;
}

/** The backend's notifications and its lifecycle, told to every twin. */
function watchBackend(backend: BackendSupervisor, twins: Map<string, Twin>): void {
  backend.sim.on("robot.state", (p) => twins.get(p.robot)?.onState(p));
  backend.sim.on("robot.collision", (p) => twins.get(p.robot)?.onCollision(p.contacts, p.positions));
  backend.on("down", (reason) => {
    for (const t of twins.values()) t.setStatus({ lastError: { code: "E_BACKEND_DOWN", message: `simulation backend down (${reason}); restarting` } });
  });
  backend.on("restartFailed", (err, attempt) => {
    const message = `simulation backend restart ${attempt} failed (${err.message}); retrying`;
    for (const t of twins.values()) t.setStatus({ lastError: { code: "E_BACKEND_DOWN", message } });
    process.emitWarning(`robwot serve: ${message}`, { code: "ROBWOT_BACKEND_RESTART" });
  });
  backend.on("up", (n) => {
    for (const t of twins.values()) {
      t.setStatus({ state: t.busy ? t.status.state : "idle", lastError: { code: "E_BACKEND_RESTARTED", message: `simulation backend restarted (${n}); state restored` } });
    }
  });
}

/** The physical robot's relay and the followed Thing, once the servient listens: targets that are the
 *  servient itself (or a relayed TD whose forms point back at it) refused. */
async function connectPeers(
  opts: ServientOptions,
  wot: typeof WoT,
  outbound: Outbound,
  at: { host: string; port: number; registerUrl: string | null },
  twins: number,
  jointNames: string[],
): Promise<{ relay: Relay | null; relayMap: RelayMap | null; followUrl: string | null }> {
  // URL userinfo becomes an Authorization header of that origin; only the URL without it is shown
  const relayUrl = opts.relay ? outbound.authorize(opts.relay) : null;
  const followUrl = opts.follow === false ? null : opts.follow ? outbound.authorize(opts.follow) : twins === 1 ? relayUrl : null;
  const relayMap: RelayMap | null = opts.relayMap ? loadRelayMap(opts.relayMap, jointNames) : null;
  const relay = relayUrl ? new Relay(wot as never, relayUrl, relayMap) : null;
  // a target that is this servient itself would send each request (a stop: each stop) back to it
  outbound.listening(at.host, at.port);
  for (const [what, target] of [["--relay", relayUrl], ["--follow", followUrl], ["--register", at.registerUrl]] as const) {
    if (target) await outbound.refuseSelf(target, what);
  }
  if (relay && relayUrl) {
    // a physical TD unreachable now is retried at the first command (failures are reported); one whose
    // forms point back at this servient is refused
    const td = await relay.connect().catch((err: unknown) => (err instanceof LoopError ? Promise.reject(err) : null));
    if (td) await outbound.refuseSelfForms(td, relayUrl, "--relay");
  }
  return { relay, relayMap, followUrl };
}

export async function startServient(opts: ServientOptions): Promise<RunningServient> {
  const host = opts.host ?? "127.0.0.1";
  const realtime = checkOptions(opts, host);
  const outbound = new Outbound();
  const connector = opts.backendUrl ? urlConnector(opts.backendUrl) : launchConnector({ python: opts.python });
  // the world is built from the twins below; restore runs only at start()
  const backend: BackendSupervisor = new BackendSupervisor(connector, (call) => world.restore(call), { mapError: fromBackendError });
  const twins = nameTwins(opts, backend);
  const world = new SceneRecord([...twins.values()], opts.meshRoots ?? []);
  const scan = scanSource(opts, backend, world, twins);
  // the device's TD and map are checked against the twin before a backend is started for it
  const devices = prepareDevices(opts.as ?? [], twins);
  watchBackend(backend, twins);
  // the twin folders are checked completely before a backend is started for them
  const checks = new Map(await Promise.all([...twins].map(async ([s, t]) => [s, await loadWorkspaceChecks(t.folder.dir)] as const)));
  // a port taken by another server is said before the backend starts, not after it
  await portFree(host, opts.port ?? 8080);
  await backend.start();

  const served = new Map<string, ServedThing>();
  const urls = { url: "", live: "" };
  let port = 0;
  const guard = new RequestGuard({ host, port: () => port, corsOrigins: opts.corsOrigins ?? [], allowedHosts: opts.allowedHosts ?? [] });
  const viewerDir = opts.viewerDir ?? defaultViewerDir(dirname(fileURLToPath(import.meta.url)));
  const middleware = createMiddleware({
    auth: opts.auth,
    guard,
    things: served,
    viewerDir: existsSync(viewerDir) ? viewerDir : null,
    index: () => ({ url: urls.url, live: urls.live, viewer: `${urls.url}/viewer/`, security: opts.auth?.scheme ?? "nosec", things: thingInfos(twins, urls.url), devices: deviceInfos(devices, served, urls.url), ...(scan ? { scan: scan.status() } : {}) }),
    directory: { url: () => urls.url, tds: () => [...served.values()].map((t) => t.td()), auth: opts.auth },
    hop: outbound.token,
  });
  const { servient, http } = nodeWot(host, opts.port ?? 8080, middleware, outbound);
  let live: LiveServer | null = null;
  const exposed: ExposedTwin[] = [];
  let cell: ExposedCell | null = null;
  const shown: RunningServient["peers"] = {};
  const { registerUrl, registrar } = registration(opts, outbound, served);
  try {
    const wot = await servient.start();
    port = http.getPort();
    const urlHost = host === "0.0.0.0" || host === "::" ? "127.0.0.1" : host.includes(":") ? `[${host}]` : host;
    urls.url = `http://${urlHost}:${port}`;
    urls.live = `ws://${urlHost}:${port}/live`;
    // the port is known only now (port 0): node-wot's forms must use the address actually served
    (http as unknown as { baseUri: string }).baseUri = urls.url;
    const jointNames = Object.keys(([...twins.values()][0]?.folder.td.properties?.["getJointPosition"]?.properties ?? {}) as object);
    const peers = await connectPeers(opts, wot, outbound, { host, port, registerUrl }, twins.size, jointNames);
    if (peers.relay) shown.relay = peers.relay.url;
    if (peers.followUrl) shown.follow = peers.followUrl;
    if (registerUrl) shown.register = registerUrl;
    const follow = {
      ...(opts.followRate !== undefined ? { rate: opts.followRate } : {}),
      ...(opts.divergenceBound !== undefined ? { divergenceBound: opts.divergenceBound } : {}),
      ...(opts.monitor !== undefined ? { monitor: opts.monitor } : {}),
      ...(opts.horizon !== undefined ? { horizon: opts.horizon } : {}),
    };
    const env: ExposeEnv = { wot, backend, world, realtime, auth: opts.auth, url: urls.url, liveUrl: urls.live, ...peers, follow, changed: (id) => registrar?.changed(id) };
    await exposeAll(env, twins, checks, devices, served, exposed);
    cell = await exposeCell({ wot, backend, world, realtime, url: urls.url, auth: opts.auth, reserved: RESERVED_SEGMENTS }, served);
    live = attachLive(http.getServer() as import("node:http").Server, twins, world, opts.auth, guard);
    for (const t of exposed) t.follower?.start();
    if (registrar) await registrar.start();
    scan?.start();
  } catch (err) {
    for (const t of exposed) t.follower?.stop();
    await cell?.stop();
    // start-up failed: the original error is rethrown below, a failing shutdown adds nothing to it
    await servient.shutdown().catch(() => undefined);
    outbound.close();
    await backend.stop();
    throw err;
  }

  let stopping: Promise<void> | null = null;
  return {
    url: urls.url,
    liveUrl: urls.live,
    things: thingInfos(twins, urls.url),
    devices: deviceInfos(devices, served, urls.url),
    backend,
    twins,
    peers: shown,
    ...(scan ? { scan: scan.status().source } : {}),
    stop: () => (stopping ??= (scan?.stop(), cell?.stop() ?? Promise.resolve()).then(() => shutdown({ exposed, registrar, live, servient, http, outbound, backend }))),
  };
}

/** `--scan-source`: the scene kept current from a sensor, told when a twin's joints change. */
function scanSource(opts: ServientOptions, backend: BackendSupervisor, world: SceneRecord, twins: Map<string, Twin>): ScanSource | null {
  if (!opts.scanSource) return null;
  const scan = new ScanSource(opts.scanSource, backend, world, new Outbound({ ...OUTBOUND_LIMITS, maxBytes: MAX_FRAME_BYTES }));
  for (const t of twins.values()) t.on("joints", () => scan.moved());
  return scan;
}

/** `--register`: the directory's URL (userinfo becomes an Authorization header of that origin; only the
 *  URL without it is shown) and the registrar of the served TDs. */
function registration(opts: ServientOptions, outbound: Outbound, served: Map<string, ServedThing>): { registerUrl: string | null; registrar: Registrar | null } {
  const registerUrl = opts.register ? outbound.authorize(opts.register) : null;
  const tds = (): { id: string; td: () => Record<string, unknown> }[] => [...served.values()].flatMap((t) => (typeof t.td().id === "string" ? [{ id: t.td().id as string, td: () => t.td() }] : []));
  return { registerUrl, registrar: registerUrl ? new Registrar(outbound, registerUrl, tds) : null };
}

/** Each twin exposed (its Thing, Mover, Follower, served routes), then the device it answers as (`--as`). */
async function exposeAll(
  env: ExposeEnv,
  twins: Map<string, Twin>,
  checks: Map<string, WorkspaceChecks | null>,
  devices: PreparedDevice[],
  served: Map<string, ServedThing>,
  exposed: ExposedTwin[],
): Promise<void> {
  for (const [slug, twin] of twins) {
    const t = await exposeTwin(env, slug, twin, checks.get(slug) ?? null);
    exposed.push(t);
    served.set(slug, t.served);
  }
  for (const device of devices) {
    const twin = twins.get(device.twin);
    const behind = served.get(device.twin);
    if (twin && behind) served.set(device.name, exposeDevice(device, { url: env.url, auth: env.auth, twin, behind }));
  }
}

/** Each `--as` device's TD and map checked against the twin answering as it; their paths distinct. */
function prepareDevices(specs: readonly AsDeviceSpec[], twins: Map<string, Twin>): PreparedDevice[] {
  const taken = new Set([...twins.keys(), ...RESERVED_SEGMENTS]);
  const tds = new Map([...twins].map(([slug, t]) => [slug, t.folder.td] as const));
  return specs.map((spec) => {
    const device = prepareDevice(spec, tds, taken);
    taken.add(device.name);
    return device;
  });
}

/** What `robwot.json` and the start-up banner say of the devices twins answer as. */
function deviceInfos(devices: readonly PreparedDevice[], served: Map<string, ServedThing>, url: string): DeviceInfo[] {
  return devices.flatMap((device) => {
    const thing = served.get(device.name);
    if (!thing) return [];
    const td = thing.td();
    return [{ name: device.name, id: String(td["id"]), title: String(td["title"]), tdUrl: `${url}/${device.name}`, twin: device.twin }];
  });
}

/** What `robwot.json` and the start-up banner say of each served twin. */
function thingInfos(twins: Map<string, Twin>, url: string): ThingInfo[] {
  return [...twins].map(([slug, t]) => ({
    slug,
    id: t.folder.td.id ?? slug,
    title: t.folder.td.title,
    tdUrl: `${url}/${slug}`,
    viewerUrl: `${url}/viewer/?thing=${encodeURIComponent(slug)}`,
  }));
}

/** Stops a started servient: first, while node-wot's HTTP client still works, a relayed command running on
 *  the physical robot is stopped there (the servient that watched it is going away); then the followers,
 *  the directory registration, /live, node-wot and the backend. */
async function shutdown(s: {
  exposed: ExposedTwin[];
  registrar: Registrar | null;
  live: LiveServer | null;
  servient: InstanceType<typeof Servient>;
  http: InstanceType<typeof HttpServer>;
  outbound: Outbound;
  backend: BackendSupervisor;
}): Promise<void> {
  await Promise.all(s.exposed.map((t) => t.mover.shutdown()));
  for (const t of s.exposed) t.follower?.stop();
  await s.registrar?.stop();
  await s.live?.close();
  // stopping: node-wot failing to unregister a Thing changes nothing, the server closes anyway
  const shut = s.servient.shutdown().catch(() => undefined);
  // long-poll observers (node-wot) hold requests open: close() alone would wait for them forever
  (s.http.getServer() as import("node:http").Server).closeAllConnections();
  await shut;
  s.outbound.close();
  await s.backend.stop();
}

/** node-wot's servient with its HTTP server (RobWoT's router as its middleware) and the bounded client. */
function nodeWot(host: string, port: number, middleware: ReturnType<typeof createMiddleware>, outbound: Outbound) {
  // node-wot reads PORT / WOT_PORT from the environment before its config: keep them out
  const saved = { PORT: process.env.PORT, WOT_PORT: process.env.WOT_PORT };
  delete process.env.PORT;
  delete process.env.WOT_PORT;
  const http = new HttpServer({ port, address: host, middleware });
  Object.assign(process.env, Object.fromEntries(Object.entries(saved).filter(([, v]) => v !== undefined)));
  const servient = new Servient();
  servient.addServer(http);
  // every request to another Thing is bounded (deadlines, size cap, no loops, no credentials shown)
  servient.addClientFactory(boundedHttpClientFactory(outbound));
  return { servient, http };
}

/** Resolves when `port` (0: any) can be bound on `host`; else throws naming both. */
function portFree(host: string, port: number): Promise<void> {
  if (port === 0) return Promise.resolve();
  return new Promise((resolve, reject) => {
    const probe = createServer();
    probe.once("error", (err: NodeJS.ErrnoException) =>
      reject(new Error(err.code === "EADDRINUSE" ? `port ${port} on ${host} is in use (choose another with --port, or --port 0 for a free one)` : `cannot listen on ${host}:${port}: ${err.message}`)),
    );
    probe.listen(port, host, () => probe.close(() => resolve()));
  });
}
