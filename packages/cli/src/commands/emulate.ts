/** `robwot emulate <twin-folder>`: a stand-in physical robot served as a Thing (servient's `emulate.ts`). */
import { parseArgs } from "node:util";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { startEmulator, type EmulatorOptions } from "@robwot/servient";
import { existingFile, parseInteger, parseNumber, usageError } from "../args.js";
import { CliError } from "../errors.js";
import { onCleanup } from "../lifecycle.js";
import { robwotWarnings } from "./serve.js";
import { checkTwinFolder, isLoopback, parseAllowedHosts, parseAuth, parseCorsOrigins } from "./serve-options.js";

export const USAGE = `Usage: robwot emulate <twin-folder> [options]

Serves a stand-in for the physical robot of a twin folder: a Thing with the twin's affordance names
(getJointPosition, motionStatus, moveToJointPosition, moveToCartesianPosition, stop) and jog, as a pendant
has. It moves where it is told within its own limits and does not know the scene; serve a twin with
--relay and --follow at its TD URL to command and mirror it. It is guarded as robwot serve is: Host and
Origin checks, no CORS but for --cors-origin, bodies of at most 1 MiB, inputs checked against its TD.
With --camera it is also a depth camera fixed in the cell: its pointCloud property answers a binary PLY
(float32 x y z in the camera's optical frame, the camera's pose in the world as its viewpoint comment)
captured on request, the robot where it really is then.

Options:
  --port N               HTTP port (default 8081; 0 = any free port)
  --host ADDR            interface to bind (default 127.0.0.1)
  --latency MS           ms between a command's arrival and the motion's start (default 0)
  --lag S                time constant (s) of the reported joints' first-order lag behind the true ones (default 0)
  --noise RAD            standard deviation (rad or m) of the noise on the reported joints (default 0)
  --velocity-scale F     fraction of the URDF velocity limits it moves at, at speed 1 (default 1)
  --auth basic:USER:PASS | bearer:TOKEN   require credentials for everything, the TD included
  --cors-origin ORIGIN   let a web page of this origin call it (CORS and commands); repeatable
  --allowed-host NAME    accept this name in the Host header besides the bound address; repeatable
  --json                 print the TD URL as JSON on stdout

Depth camera:
  --camera X,Y,Z:TX,TY,TZ   the camera's position and the point it looks at (m, world frame); enables it
                         (a value starting with a minus sign: --camera=-1,0,1:0,0,0)
  --camera-size WxH      pixels (default 320x240)
  --camera-noise M       depth noise (m, standard deviation at 1 m, growing with the square of the depth;
                         default 0.001)
  --camera-dropout P     the share of pixels returning nothing (default 0.01)
  --scene FILE           the cell the camera sees, a scene file as robwot generate --scene takes (default:
                         the twin folder's scene.json when it holds obstacles, objects or other robots); a
                         scene robot standing on the emulated robot's base is that robot (left out)
`;

const CAMERA_OPTIONS = ["camera-size", "camera-noise", "camera-dropout", "scene"] as const;
type CameraValues = { camera?: string } & { [K in (typeof CAMERA_OPTIONS)[number]]?: string };

/** `X,Y,Z` of `--camera`: three finite numbers within the contract's positions (m). */
function point(text: string, what: string, raw: string): [number, number, number] {
  const { minimum, maximum } = VALUE_SCHEMAS.Position.items;
  const v = text.split(",").map((x) => (x.trim() === "" ? NaN : Number(x)));
  if (v.length !== 3 || v.some((x) => !Number.isFinite(x))) {
    throw new CliError(`--camera must be X,Y,Z:TX,TY,TZ (the camera's position and the point it looks at, m), got "${raw}"`);
  }
  if (v.some((x) => x < minimum || x > maximum)) throw new CliError(`--camera: the ${what}'s coordinates must be between ${minimum} and ${maximum} m, got "${text}"`);
  return v as [number, number, number];
}

/** `--camera X,Y,Z:TX,TY,TZ` and its `--camera-*` and `--scene` options; undefined without `--camera`. */
export function parseCamera(values: CameraValues): EmulatorOptions["camera"] {
  if (values.camera === undefined) {
    const stray = CAMERA_OPTIONS.find((o) => values[o] !== undefined);
    if (stray) throw new CliError(`--${stray} goes with --camera (the depth camera it sets up)`);
    return undefined;
  }
  const halves = values.camera.split(":");
  if (halves.length !== 2) throw new CliError(`--camera must be X,Y,Z:TX,TY,TZ (the camera's position and the point it looks at, m), got "${values.camera}"`);
  const position = point(halves[0]!, "position", values.camera);
  const target = point(halves[1]!, "target", values.camera);
  const view = target.map((t, i) => t - position[i]!);
  if (Math.hypot(...view) === 0) throw new CliError(`--camera: the point looked at must differ from the camera's position, got "${values.camera}"`);
  // straight up or down: the image's up (the world's z) along the view; a view within a hair of it is
  // refused by the backend's own camera check at the first frame, naming camera.up
  if (Math.hypot(view[0]!, view[1]!) === 0) {
    throw new CliError(`--camera must not look straight up or down (the image's up is the world's z), got "${values.camera}"`);
  }
  const size = /^\s*(\d+)\s*x\s*(\d+)\s*$/i.exec(values["camera-size"] ?? "320x240");
  const [width, height] = [Number(size?.[1]), Number(size?.[2])];
  if (!size || !(width >= 1 && width <= 4096 && height >= 1 && height <= 4096)) {
    throw new CliError(`--camera-size must be WxH, each 1 to 4096 pixels (e.g. 320x240), got "${values["camera-size"]}"`);
  }
  const noise = VALUE_SCHEMAS.ScanNoise;
  return {
    position,
    target,
    width,
    height,
    noise: parseNumber("camera-noise", values["camera-noise"], 0.001, noise.minimum, noise.maximum),
    dropout: parseNumber("camera-dropout", values["camera-dropout"], 0.01, 0, 1),
    ...(values.scene !== undefined ? { scene: existingFile("--scene file", values.scene) } : {}),
  };
}

export async function run(argv: string[]): Promise<number> {
  let parsed;
  const options = {
    port: { type: "string" },
    host: { type: "string" },
    latency: { type: "string" },
    lag: { type: "string" },
    noise: { type: "string" },
    "velocity-scale": { type: "string" },
    auth: { type: "string" },
    "cors-origin": { type: "string", multiple: true },
    "allowed-host": { type: "string", multiple: true },
    json: { type: "boolean" },
    camera: { type: "string" },
    "camera-size": { type: "string" },
    "camera-noise": { type: "string" },
    "camera-dropout": { type: "string" },
    scene: { type: "string" },
  } as const;
  try {
    parsed = parseArgs({ args: argv, options, allowPositionals: true, strict: true });
  } catch (err) {
    throw usageError(err, "emulate", Object.keys(options));
  }
  const { values, positionals } = parsed;
  if (positionals.length !== 1) throw new CliError("give one twin folder (robwot emulate <twin-folder>)");
  const host = values.host ?? "127.0.0.1";
  if (host.trim() === "") throw new CliError("--host must not be empty");
  const auth = parseAuth(values.auth);
  const camera = parseCamera(values);
  const opts = {
    folder: checkTwinFolder(positionals[0]!),
    port: parseInteger("port", values.port, 8081, 0, 65535),
    host,
    latencyMs: parseNumber("latency", values.latency, 0, 0, 10_000),
    lag: parseNumber("lag", values.lag, 0, 0, 10),
    noise: parseNumber("noise", values.noise, 0, 0, 0.1),
    velocityScale: parseNumber("velocity-scale", values["velocity-scale"], 1, 0.01, 1),
    ...(auth ? { auth } : {}),
    corsOrigins: parseCorsOrigins(values["cors-origin"]),
    allowedHosts: parseAllowedHosts(values["allowed-host"]),
    ...(camera ? { camera } : {}),
  };
  robwotWarnings();
  if (!isLoopback(host) && !auth) {
    process.stderr.write(`robwot: warning: binding ${host} without --auth: anyone on the network can move the robot\n`);
  }
  const emulator = await startEmulator(opts);
  onCleanup(() => emulator.stop());
  process.stdout.write(values.json ? `${JSON.stringify({ url: emulator.url, tdUrl: emulator.tdUrl })}\n` : `robwot: emulating at ${emulator.tdUrl} (Ctrl-C to stop)\n`);
  return new Promise<number>(() => undefined);
}
