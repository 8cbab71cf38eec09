/**
 * What `robwot generate` checks of its options before it asks a backend anything, beyond parsing them (an own
 * backend's process starts meanwhile and is stopped on a refusal): `--ee`
 * against the links of the robot's URDF file (a plain URDF, or an example's), and `--cluster` (Ray in the
 * Python that will run the backend; something listening at an explicit address). Each refusal names the
 * option and costs milliseconds. What cannot be known here is left to the backend, which checks it all
 * again: the links of a xacro or a MoveIt config (known once expanded), a remote backend's Python and
 * network, and whether `auto` finds a running Ray cluster.
 */
import { execFile } from "node:child_process";
import { readFileSync } from "node:fs";
import { connect } from "node:net";
import { TRANSPORT } from "@robwot/core/backend-contract";
import { resolvePython } from "@robwot/sim-client/spawn";
import type { GenerateOptions } from "./commands/generate-options.js";
import { CliError } from "./errors.js";
import { exampleUrdfPath } from "./examples.js";

/** What the backend's Python has, found without importing either package (milliseconds, not seconds). */
interface PythonFacts {
  /** the `pybullet_data` folder (the example robots' files) */
  pybulletData: string | null;
  ray: boolean;
}

const FACTS_SCRIPT = [
  "import importlib.util as u, json",
  'd = u.find_spec("pybullet_data")',
  'print(json.dumps({"pybulletData": list(d.submodule_search_locations)[0] if d else None, "ray": u.find_spec("ray") is not None}))',
].join("\n");

/** The facts of the Python an own backend runs on; null when it cannot run (the launch says why). */
function pythonFacts(python: string): Promise<PythonFacts | null> {
  return new Promise((resolve) => {
    execFile(python, ["-c", FACTS_SCRIPT], { timeout: TRANSPORT.startTimeoutMs }, (err, stdout) => {
      try {
        resolve(err ? null : (JSON.parse(stdout) as PythonFacts));
      } catch {
        resolve(null);
      }
    });
  });
}

/**
 * The `<link name>`s of a URDF's text, sorted; null when they cannot be read without an XML parser (a
 * DOCTYPE may define entities; `${...}` or `$(...)` is an unexpanded xacro): the backend then decides.
 */
export function urdfLinks(text: string): string[] | null {
  const xml = text.replace(/<!--[\s\S]*?-->/g, "");
  if (/<!DOCTYPE/i.test(xml)) return null;
  const names = [...xml.matchAll(/<link[\s/>][^>]*?\bname\s*=\s*(["'])(.*?)\1/g)].map((m) => m[2] ?? "");
  if (names.some((n) => n.includes("$"))) return null;
  return names.sort();
}

/** The URDF file whose links `--ee` names, when it is known before a backend runs. */
function urdfFileOf(opts: GenerateOptions, facts: PythonFacts | null): string | undefined {
  if (opts.moveitConfig !== undefined || opts.urdfFile?.endsWith(".xacro")) return undefined;
  if (opts.urdfFile !== undefined) return opts.urdfFile;
  if (opts.example?.source === "bundled") return exampleUrdfPath(opts.example, "");
  if (opts.example !== undefined && facts?.pybulletData) return exampleUrdfPath(opts.example, facts.pybulletData);
  return undefined;
}

function checkEndEffector(ee: string, file: string): void {
  let text: string;
  try {
    text = readFileSync(file, "utf8");
  } catch {
    return; // the backend names the file it cannot read
  }
  const links = urdfLinks(text);
  if (links === null || links.includes(ee)) return;
  // the backend's words and code for the same refusal
  throw new CliError(`--ee: unknown link '${ee}' in ${file}; available: ${links.join(", ")}`, "E_UNKNOWN_LINK", 1);
}

/** `host` and `port` of a `[ray://]host:port` address; null for anything else. */
function clusterEndpoint(address: string): { host: string; port: number } | null {
  const m = /^(?:[a-z]+:\/\/)?(.+):(\d+)\/?$/.exec(address);
  return m ? { host: (m[1] ?? "").replace(/^\[|\]$/g, ""), port: Number(m[2]) } : null;
}

/** Resolves once something accepts a TCP connection at `host:port`; a refusal naming the address otherwise. */
function reachable(address: string, host: string, port: number): Promise<void> {
  return new Promise((resolve, reject) => {
    // as long as a backend's own handshake may take
    const socket = connect({ host, port, timeout: TRANSPORT.connectTimeoutMs });
    const fail = (why: string): void => {
      socket.destroy();
      reject(new CliError(`--cluster: cannot connect to the Ray cluster at '${address}': ${why}`, "E_CLUSTER", 1));
    };
    socket.once("connect", () => {
      socket.destroy();
      resolve();
    });
    socket.once("timeout", () => fail("no answer"));
    socket.once("error", (err: NodeJS.ErrnoException) => fail(err.code ?? err.message));
  });
}

/** `--cluster`: an address of the right form (any backend); for an own backend, Ray in its Python and, for
 *  an explicit address (or `auto` through RAY_ADDRESS), something listening there. */
async function checkCluster(address: string, own: boolean, python: string, facts: PythonFacts | null): Promise<void> {
  if (address !== "auto" && clusterEndpoint(address) === null) throw new CliError(`--cluster must be auto, ray://HOST:PORT or HOST:PORT, got "${address}"`);
  if (!own) return;
  if (facts !== null && !facts.ray) {
    throw new CliError(
      `--cluster needs Ray in the backend's Python (${python}): install the backend with the cluster extra ` +
        "(ROBWOT_EXTRAS=cluster npm install, or pip install 'robwot-sim[cluster]')",
      "E_CLUSTER",
      1,
    );
  }
  // `auto` is RAY_ADDRESS, else a cluster Ray finds on this machine by its own means
  const explicit = address === "auto" ? process.env["RAY_ADDRESS"] : address;
  const endpoint = explicit === undefined ? null : clusterEndpoint(explicit);
  if (explicit !== undefined && endpoint !== null) await reachable(explicit, endpoint.host, endpoint.port);
}

/** Refuses, before a backend is asked anything, an option the robot's files or this machine already contradict. */
export async function preflight(opts: GenerateOptions): Promise<void> {
  // a backend someone else runs has its own Python, files and network
  const own = opts.backend === undefined;
  const needFacts = own && (opts.cluster !== undefined || (opts.ee !== undefined && opts.example?.source === "pybullet_data"));
  const python = resolvePython();
  const facts = needFacts ? await pythonFacts(python) : null;
  const urdf = opts.ee !== undefined ? urdfFileOf(opts, facts) : undefined;
  if (opts.ee !== undefined && urdf !== undefined) checkEndEffector(opts.ee, urdf);
  if (opts.cluster !== undefined) await checkCluster(opts.cluster, own, python, facts);
}
