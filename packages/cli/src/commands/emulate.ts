/** `robwot emulate <twin-folder>`: a stand-in physical robot served as a Thing (servient's `emulate.ts`). */
import { parseArgs } from "node:util";
import { startEmulator } from "@robwot/servient";
import { parseInteger, parseNumber, usageError } from "../args.js";
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
`;

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
