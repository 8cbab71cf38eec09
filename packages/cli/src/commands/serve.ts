/** `robwot serve`: wires CLI flags to the servient (`@robwot/servient`) and prints where things are. */
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { AsDeviceError, DIVERGENCE_BOUND, FOLLOW_RATE, MONITOR_HORIZON, startServient, type RunningServient } from "@robwot/servient";
import { CliError } from "../errors.js";
import { onCleanup } from "../lifecycle.js";
import { isLoopback, parseServeArgs, type ServeOptions } from "./serve-options.js";

export const USAGE = `Usage: robwot serve <twin-folder>... [options]

Serves twin folders (made by robwot generate) as node-wot Things over HTTP, with live state on the
/live WebSocket and the browser viewer at /viewer/. Several folders share one simulated world; a cell
folder (a folder of twin folders) serves each twin in it.

Options:
  --port N, -p N               HTTP port (default 8080; 0 = any free port)
  --host ADDR                  interface to bind (default 127.0.0.1)
  --realtime F                 motion speed vs wall clock (default 1; 0 = as fast as possible, else ${VALUE_SCHEMAS.RealtimeFactor.minimum}-${VALUE_SCHEMAS.RealtimeFactor.maximum})
  --relay URL                  TD URL of the physical robot's Thing: validated commands are relayed there;
                               with one twin folder the twin also mirrors it (as --follow URL)
  --follow URL                 TD URL of the physical robot the twin mirrors: its joints read --follow-rate
                               times a second (default ${FOLLOW_RATE.default}) into the property physicalState; when it moves
                               without a twin command the twin is set to its state. One twin folder
  --no-follow                  relay without mirroring (a physical Thing whose joint state cannot be read)
  --follow-rate HZ             readings of the physical robot per second (${FOLLOW_RATE.minimum}-${FOLLOW_RATE.maximum})
  --divergence-bound RAD       while a command is relayed, a physical joint this far from the simulated motion at
                               the same time emits the divergence event (default ${DIVERGENCE_BOUND})
  --monitor stop|warn|off      the safety monitor on the followed robot: a contact predicted within --horizon
                               at its current joint velocity emits collisionImminent and (stop, the default)
                               stops it through its Thing
  --horizon S                  how far ahead the monitor looks beyond what it measures (default ${MONITOR_HORIZON} s): it
                               must cover the robot's unmeasured reporting lag and its time to act on a stop;
                               no usable reading for this long plus one poll period is a monitor fault
  --relay-map FILE             JSON naming the physical Thing's own joint state property, joint order and units,
                               and its joint move, Cartesian move and stop actions (README "--relay-map")
  --register URL               a Thing Description Directory (WoT Discovery) to register the TDs into
                               (PUT URL/things/{id}; again after calibrate; DELETE on exit)
  --auth basic:USER:PASS | bearer:TOKEN   require credentials for every affordance and file
  --backend ws://HOST:PORT     use a running backend instead of starting one
  --cors-origin ORIGIN         let a web page of this origin (e.g. https://dash.example:3000) call the twin;
                               repeatable. Default: no other origin may send commands or read via CORS
  --mesh-root DIR              folder that addObstacle mesh files may come from, besides the twin folders;
                               repeatable (any other path is refused with 403)
  --allowed-host NAME          accept this name in the Host header besides the bound address (e.g. the
                               machine's DNS name with --host 0.0.0.0); repeatable
  --as DEVICE=TD.json          also serve a twin as a physical device, at /DEVICE, with that device's own TD
                               (its affordance names, schemas, integer types, ranges, units; our forms and
                               security): a mashup written for the device runs unchanged against the twin
                               (README "Serving a real device's TD"); repeatable, one per device
  --as-map [DEVICE=]FILE       JSON mapping each affordance of the device's TD onto the twin's (units, frame
                               offset, orientation, sequences, "unsupported", with several twin folders the
                               twin); default: inferred by name and shape. DEVICE= when several --as
  --scan-source SRC            keep the scene current from a sensor's point clouds (PLY, PCD or XYZ): a
                               folder (its newest file, again when one is written), an http(s):// URL
                               (fetched every --scan-period) or a ws(s):// URL (each binary message a
                               frame); obstacles scan-N added, moved and removed as addObstacle/
                               moveObstacle/removeObstacle would (README "The scene from a scan")
  --scan-pose X,Y,Z[,QX,QY,QZ,QW]   the sensor's pose in the world (default: each frame's own viewpoint)
  --scan-noise M               the sensor's noise bound, every point grown by it (default 0.005)
  --scan-period S              seconds between fetches of an http(s) source and looks at a folder (default 0.5)
  --json                       print the URLs as JSON on stdout
`;

/** Node prints process warnings as `(node:PID) Warning: ...`: print them as `robwot: warning: ...`. */
export function robwotWarnings(): void {
  process.removeAllListeners("warning");
  process.on("warning", (w) => {
    // the servient's (and the emulator's) own no-auth warning: already said by the command in CLI terms
    if ((w as Error & { code?: string }).code === "ROBWOT_NO_AUTH") return;
    process.stderr.write(`robwot: warning: ${w.message}\n`);
  });
}

export function printServing(s: RunningServient, json: boolean): void {
  if (json) {
    process.stdout.write(`${JSON.stringify({ url: s.url, liveUrl: s.liveUrl, viewer: `${s.url}/viewer/`, things: s.things, devices: s.devices, peers: s.peers })}\n`);
    return;
  }
  const lines = [`robwot: serving ${s.things.length} twin(s) at ${s.url} (Ctrl-C to stop)`];
  for (const t of s.things) {
    lines.push(`  ${t.title}`, `    TD      ${t.tdUrl}`, `    viewer  ${t.viewerUrl}`);
  }
  for (const d of s.devices) lines.push(`  ${d.title} (the twin ${d.twin} as --as ${d.name})`, `    TD      ${d.tdUrl}`);
  lines.push(`  live WebSocket ${s.liveUrl}`);
  // where commands go and what is watched: the physical robot's Thing, the directory (credentials never shown)
  if (s.peers.relay) lines.push(`  relays to      ${s.peers.relay}`);
  if (s.peers.follow) lines.push(`  follows        ${s.peers.follow}`);
  if (s.peers.register) lines.push(`  registered at  ${s.peers.register}`);
  if (s.scan) lines.push(`  scene from     ${s.scan}`);
  process.stdout.write(`${lines.join("\n")}\n`);
}

/** Starts the servient and keeps running until SIGINT/SIGTERM (then stops it and the backend). */
export async function serve(opts: ServeOptions): Promise<number> {
  robwotWarnings();
  if (!isLoopback(opts.host) && !opts.auth) {
    process.stderr.write(`robwot: warning: binding ${opts.host} without --auth: anyone on the network can move the robot\n`);
  }
  const running = await startServient({
    ...(opts.as ? { as: opts.as } : {}),
    twins: opts.folders,
    host: opts.host,
    port: opts.port,
    realtime: opts.realtime,
    ...(opts.relay ? { relay: opts.relay } : {}),
    ...(opts.relayMap ? { relayMap: opts.relayMap } : {}),
    ...(opts.follow === false ? { follow: false as const } : {}),
    ...(opts.follow
      ? { follow: opts.follow, followRate: opts.followRate, divergenceBound: opts.divergenceBound, monitor: opts.monitor, horizon: opts.horizon }
      : {}),
    ...(opts.auth ? { auth: opts.auth } : {}),
    ...(opts.backend ? { backendUrl: opts.backend } : {}),
    ...(opts.register ? { register: opts.register } : {}),
    corsOrigins: opts.corsOrigins,
    allowedHosts: opts.allowedHosts,
    meshRoots: opts.meshRoots ?? [],
    ...(opts.scanSource ? { scanSource: opts.scanSource } : {}),
  }).catch((err: unknown) => {
    // the device's TD or map refused: a usage error, said as such
    throw err instanceof AsDeviceError ? new CliError(err.message, "E_USAGE", 2) : err;
  });
  onCleanup(() => running.stop());
  printServing(running, opts.json);
  return new Promise<number>(() => undefined);
}

export async function run(argv: string[]): Promise<number> {
  return serve(parseServeArgs(argv));
}
