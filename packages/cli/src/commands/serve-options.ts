/** `robwot serve` options, validated before anything starts (folders exist and hold a twin, URLs parse). */
import { existsSync, readdirSync, statSync } from "node:fs";
import { isIP } from "node:net";
import { join, resolve } from "node:path";
import { parseArgs } from "node:util";
import { TWIN_FILES } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { DIVERGENCE_BOUND, FOLLOW_RATE, MONITOR_HORIZON, type MonitorMode, type ScanSourceOptions } from "@robwot/servient";
import { parseInteger, parseNumber, parseRealtime, parseUrl, usageError } from "../args.js";
import { CliError } from "../errors.js";

export type AuthOption = { scheme: "basic"; user: string; password: string } | { scheme: "bearer"; token: string };

export interface ServeOptions {
  folders: string[];
  port: number;
  host: string;
  realtime: number;
  relay?: string;
  /** the mirrored Thing (--follow, or the --relay Thing with one twin folder); false: --no-follow */
  follow?: string | false;
  followRate?: number;
  divergenceBound?: number;
  monitor?: MonitorMode;
  horizon?: number;
  relayMap?: string;
  /** base URL of a Thing Description Directory the TDs are registered into (--register) */
  register?: string;
  auth?: AuthOption;
  backend?: string;
  /** browser origins granted CORS and allowed to send commands (--cors-origin, repeatable) */
  corsOrigins: string[];
  /** extra names accepted in the Host header (--allowed-host, repeatable) */
  allowedHosts: string[];
  /** folders run-time mesh obstacles may come from besides the twin folders (--mesh-root, repeatable) */
  meshRoots?: string[];
  /** --as DEVICE=TD [--as-map [DEVICE=]MAP] (repeatable): twins also served as physical devices (their own TDs) */
  as?: { name: string; td: string; map?: string }[];
  /** --scan-source SRC [--scan-pose ...] [--scan-noise M] [--scan-period S]: the scene kept current from a sensor */
  scanSource?: ScanSourceOptions;
  json: boolean;
}

export const SERVE_OPTIONS = {
  port: { type: "string", short: "p" },
  host: { type: "string" },
  realtime: { type: "string" },
  relay: { type: "string" },
  follow: { type: "string" },
  "no-follow": { type: "boolean" },
  "follow-rate": { type: "string" },
  "divergence-bound": { type: "string" },
  monitor: { type: "string" },
  horizon: { type: "string" },
  "relay-map": { type: "string" },
  register: { type: "string" },
  auth: { type: "string" },
  backend: { type: "string" },
  "cors-origin": { type: "string", multiple: true },
  "allowed-host": { type: "string", multiple: true },
  "mesh-root": { type: "string", multiple: true },
  as: { type: "string", multiple: true },
  "as-map": { type: "string", multiple: true },
  "scan-source": { type: "string" },
  "scan-pose": { type: "string" },
  "scan-noise": { type: "string" },
  "scan-period": { type: "string" },
  json: { type: "boolean" },
} as const;

/** `--scan-source` (a folder, or an http(s) or ws(s) URL) and its options. */
export function parseScanSource(values: { "scan-source"?: string; "scan-pose"?: string; "scan-noise"?: string; "scan-period"?: string }): ScanSourceOptions | undefined {
  const src = values["scan-source"];
  if (src === undefined) {
    const stray = (["scan-pose", "scan-noise", "scan-period"] as const).find((o) => values[o] !== undefined);
    if (stray) throw new CliError(`--${stray} goes with --scan-source`);
    return undefined;
  }
  let source: string;
  if (/^[a-z]+:\/\//i.test(src)) {
    source = parseUrl("scan-source", src, ["http", "https", "ws", "wss"], "send")!.href;
  } else {
    source = resolve(src);
    if (!existsSync(source) || !statSync(source).isDirectory()) throw new CliError(`--scan-source: folder not found: ${source} (or give an http(s):// or ws(s):// URL)`);
  }
  const pose = values["scan-pose"]?.split(",").map((v) => Number(v.trim()));
  if (pose !== undefined && (![3, 7].includes(pose.length) || pose.some((v) => !Number.isFinite(v)))) {
    throw new CliError(`--scan-pose must be X,Y,Z or X,Y,Z,QX,QY,QZ,QW (m), got "${values["scan-pose"]}"`);
  }
  const noise = VALUE_SCHEMAS.ScanNoise;
  return {
    source,
    ...(pose ? { position: pose.slice(0, 3) as [number, number, number] } : {}),
    ...(pose?.length === 7 ? { orientation: pose.slice(3) as [number, number, number, number] } : {}),
    noise: parseNumber("scan-noise", values["scan-noise"], 0.005, noise.minimum, noise.maximum),
    periodMs: 1000 * parseNumber("scan-period", values["scan-period"], 0.5, 0.05, 60),
  };
}

/** `--cors-origin` values: absolute http(s) origins (scheme://host[:port], nothing after). */
export function parseCorsOrigins(values: readonly string[] | undefined): string[] {
  return (values ?? []).map((v) => {
    let u: URL | null = null;
    try {
      u = new URL(v);
    } catch {
      u = null;
    }
    if (!u || !["http:", "https:"].includes(u.protocol) || u.origin !== v.replace(/\/$/, "")) {
      throw new CliError(`--cors-origin must be an origin such as https://dashboard.example:3000 (scheme, host, optional port), got "${v}"`);
    }
    return u.origin;
  });
}

/** `--allowed-host` values: host names or addresses, no scheme, port or path. */
export function parseAllowedHosts(values: readonly string[] | undefined): string[] {
  return (values ?? []).map((v) => {
    if (!/^(\[[0-9a-fA-F:.]+\]|[A-Za-z0-9.-]+)$/.test(v)) throw new CliError(`--allowed-host must be a host name or address without port, got "${v}"`);
    return v;
  });
}

export function parseAuth(value: string | undefined): AuthOption | undefined {
  if (value === undefined) return undefined;
  const [scheme, ...rest] = value.split(":");
  if (scheme === "basic" && rest.length >= 2 && rest[0] !== "" && rest.slice(1).join(":") !== "") {
    return { scheme: "basic", user: rest[0] as string, password: rest.slice(1).join(":") };
  }
  if (scheme === "bearer" && rest.length >= 1 && rest.join(":") !== "") return { scheme: "bearer", token: rest.join(":") };
  throw new CliError(`--auth must be basic:USER:PASS or bearer:TOKEN, got "${value.replace(/:.*/, ":...")}"`);
}

/** 127.0.0.0/8, ::1 and localhost: reachable only from this machine. */
export function isLoopback(host: string): boolean {
  const h = host.replace(/^\[|\]$/g, "");
  if (h === "localhost" || h === "::1") return true;
  return isIP(h) === 4 && h.startsWith("127.");
}

const isTwinFolder = (dir: string): boolean => [TWIN_FILES.td, TWIN_FILES.manifest].every((f) => existsSync(join(dir, f)));

export function checkTwinFolder(folder: string): string {
  const dir = resolve(folder);
  if (!existsSync(dir) || !statSync(dir).isDirectory()) throw new CliError(`twin folder not found: ${dir}`, "E_TWIN_FOLDER", 1);
  for (const f of [TWIN_FILES.td, TWIN_FILES.manifest]) {
    if (!existsSync(join(dir, f))) {
      throw new CliError(`${dir} is not a twin folder: no ${f} (create one with robwot generate)`, "E_TWIN_FOLDER", 1);
    }
  }
  return dir;
}

/** A twin folder, or a cell folder: a folder without td.json whose subfolders holding td.json and twin.json
 *  are its twins (in name order; the cell's arms generated into one folder, README "A whole cell"). */
export function twinFoldersOf(folder: string): string[] {
  const dir = resolve(folder);
  if (existsSync(dir) && statSync(dir).isDirectory() && !existsSync(join(dir, TWIN_FILES.td))) {
    const twins = readdirSync(dir, { withFileTypes: true }).filter((e) => e.isDirectory() && isTwinFolder(join(dir, e.name))).map((e) => join(dir, e.name)).sort();
    if (twins.length > 0) return twins;
  }
  return [checkTwinFolder(dir)];
}

/** `--as DEVICE=FILE` (repeatable) and `--as-map [DEVICE=]FILE` (one per device; the bare FILE with one
 *  --as): names URL path segments, each named once, the files regular files (their content is checked
 *  when serve starts, `@robwot/servient`'s as-map.ts; with several twin folders a map names its twin). */
export function parseAs(values: string[] | undefined, maps: string[] | undefined): ServeOptions["as"] {
  if (values === undefined) {
    if (maps !== undefined) throw new CliError("--as-map goes with --as DEVICE=real-td.json");
    return undefined;
  }
  const file = (option: string, f: string): string => {
    const path = resolve(f);
    if (!existsSync(path) || !statSync(path).isFile()) throw new CliError(`${option}: file not found: ${path}`);
    return path;
  };
  const named = (option: string, value: string, what: string): [string, string] => {
    const eq = value.indexOf("=");
    const name = value.slice(0, Math.max(eq, 0));
    if (eq <= 0 || !/^[A-Za-z0-9_-]{1,64}$/.test(name) || eq === value.length - 1) {
      throw new CliError(`${option} must be DEVICE=${what}, DEVICE being the URL path segment it is served at (1-64 of A-Z a-z 0-9 _ -), got "${value.slice(0, 80)}"`);
    }
    return [name, value.slice(eq + 1)];
  };
  const devices = values.map((v) => named("--as", v, "real-td.json"));
  const names = devices.map(([n]) => n);
  const twice = names.find((n, i) => names.indexOf(n) !== i);
  if (twice !== undefined) throw new CliError(`--as names device ${twice} twice`);
  const byDevice = new Map<string, string>();
  for (const m of maps ?? []) {
    const bare = devices.length === 1 && !/^[A-Za-z0-9_-]{1,64}=/.test(m);
    const [name, f] = bare ? [names[0]!, m] : named("--as-map", m, "map.json");
    if (!names.includes(name)) throw new CliError(`--as-map ${name}: no --as ${name}=... names that device`);
    if (byDevice.has(name)) throw new CliError(`--as-map names device ${name} twice`);
    byDevice.set(name, file("--as-map", f));
  }
  return devices.map(([name, td]) => ({ name, td: file("--as", td), ...(byDevice.has(name) ? { map: byDevice.get(name)! } : {}) }));
}

const MONITOR_MODES: readonly MonitorMode[] = ["stop", "warn", "off"];

function parseMonitor(value: string | undefined): MonitorMode {
  if (value === undefined) return "stop";
  const mode = MONITOR_MODES.find((m) => m === value);
  if (!mode) throw new CliError(`--monitor must be one of ${MONITOR_MODES.join(", ")}, got "${value}"`);
  return mode;
}

export function parseServeArgs(argv: string[]): ServeOptions {
  let parsed;
  try {
    parsed = parseArgs({ args: argv, options: SERVE_OPTIONS, allowPositionals: true, strict: true });
  } catch (err) {
    throw usageError(err, "serve", Object.keys(SERVE_OPTIONS));
  }
  const { values, positionals } = parsed;
  if (positionals.length === 0) throw new CliError("missing twin folder (robwot serve <twin-folder>...)");
  const folders = positionals.flatMap(twinFoldersOf);
  const twice = folders.find((f, i) => folders.indexOf(f) !== i);
  if (twice !== undefined) {
    throw new CliError(`twin folder given twice: ${twice} (copy the folder to serve a second robot; place it in its ${TWIN_FILES.manifest})`);
  }
  const host = values.host ?? "127.0.0.1";
  if (host.trim() === "") throw new CliError("--host must not be empty");
  const relay = parseUrl("relay", values.relay, ["http", "https"], "send")?.href;
  const explicit = parseUrl("follow", values.follow, ["http", "https"], "send")?.href;
  if (values["no-follow"] && explicit !== undefined) throw new CliError("--follow URL and --no-follow contradict each other");
  if (explicit !== undefined && folders.length !== 1) throw new CliError(`--follow mirrors one physical robot into one twin: give one twin folder, not ${folders.length}`);
  // a twin that relays to one robot also mirrors it, unless told not to (a Thing without a readable joint state)
  const follow = values["no-follow"] ? undefined : (explicit ?? (folders.length === 1 ? relay : undefined));
  if (values["relay-map"] !== undefined && relay === undefined && follow === undefined) throw new CliError("--relay-map goes with --relay URL or --follow URL");
  for (const o of ["follow-rate", "divergence-bound", "monitor", "horizon"] as const) {
    if (values[o] !== undefined && follow === undefined) {
      throw new CliError(`--${o} goes with --follow URL (or --relay URL with one twin folder and without --no-follow)`);
    }
  }
  const backend = parseUrl("backend", values.backend, ["ws", "wss"])?.href;
  const register = parseUrl("register", values.register, ["http", "https"], "send")?.href;
  const auth = parseAuth(values.auth);
  const as = parseAs(values.as, values["as-map"]);
  const scanSource = parseScanSource(values);
  return {
    folders,
    port: parseInteger("port", values.port, 8080, 0, 65535),
    host,
    realtime: parseRealtime(values.realtime),
    ...(relay ? { relay } : {}),
    ...(values["relay-map"] !== undefined ? { relayMap: resolve(values["relay-map"]) } : {}),
    ...(values["no-follow"] ? { follow: false as const } : {}),
    ...(follow
      ? {
          follow,
          followRate: parseNumber("follow-rate", values["follow-rate"], FOLLOW_RATE.default, FOLLOW_RATE.minimum, FOLLOW_RATE.maximum),
          divergenceBound: parseNumber("divergence-bound", values["divergence-bound"], DIVERGENCE_BOUND, 0, 10),
          monitor: parseMonitor(values.monitor),
          horizon: parseNumber("horizon", values.horizon, MONITOR_HORIZON, 0.01, 5),
        }
      : {}),
    ...(auth ? { auth } : {}),
    ...(backend ? { backend } : {}),
    ...(register ? { register } : {}),
    corsOrigins: parseCorsOrigins(values["cors-origin"]),
    allowedHosts: parseAllowedHosts(values["allowed-host"]),
    meshRoots: (values["mesh-root"] ?? []).map((d) => {
      const dir = resolve(d);
      if (!existsSync(dir) || !statSync(dir).isDirectory()) throw new CliError(`--mesh-root: folder not found: ${dir}`);
      return dir;
    }),
    ...(as ? { as } : {}),
    ...(scanSource ? { scanSource } : {}),
    json: values.json ?? false,
  };
}
