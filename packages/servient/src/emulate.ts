/**
 * `robwot emulate <twin-folder>`: a stand-in physical robot, served as a Thing with the twin's affordance
 * names, for users without hardware and as the reference counterpart of the twin's relay and follow.
 *
 * It behaves as a robot controller does, not as a twin: it knows its joints and kinematics (the twin
 * folder's URDF, loaded into its own simulation backend for forward and inverse kinematics only) but not
 * the scene, so it moves where it is told, also into an obstacle only the twin knows about. A commanded move
 * starts after `latencyMs` and runs on a rest-to-rest trapezoid of the straight joint-space line within the
 * URDF velocity limits x `velocityScale` x the move's speed and the accelerations (a joint reaches its
 * velocity limit in the contract's `Acceleration.x-accelerationTime`). What it reports lags the true
 * joints as a first-order filter of time constant `lag` s (at a constant velocity v the report is v x lag
 * behind) plus Gaussian noise of `noise` rad. `jog` moves joints at given velocities for a time, as a
 * pendant does; a joint that reaches its limit during a jog is a protective stop. `stop` halts at once.
 *
 * With `camera` it is also a depth camera fixed in the cell (`emulate-camera.ts`): the scene it sees is loaded
 * into its backend (it still moves as if it did not know it), and its `pointCloud` property answers a frame
 * captured on request, its robot where the controller's true joints put it then.
 *
 * It is secured as the twin is (`emulate-http.ts`): Host and Origin checks, CORS only for `corsOrigins`,
 * `auth` on everything (the served TD declares it), bodies capped and inputs validated before node-wot
 * (400/413/415), handler errors with their status (409 busy, 422 out of reach); all as problem details.
 */
import { createRequire } from "node:module";
import { gaussian, mulberry32 } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { launchBackend, type LaunchedBackend } from "@robwot/sim-client";
import type { AuthConfig } from "./auth.js";
import { cameraProblem, cameraScene, DepthCamera, EMULATED_ID, loadCameraScene, POINT_CLOUD_AFFORDANCE, POINT_CLOUD_TYPE, type EmulatorCamera } from "./emulate-camera.js";
import { EmulatedController, type MotionEnd } from "./emulate-controller.js";
import { emulatorMiddleware, emulatorTd, type EmulatedThing } from "./emulate-http.js";
import { objectInput, type ActionHandler, type Affordances, type PropertyReader } from "./affordance-routes.js";
import { fromBackendError, servientError } from "./errors.js";
import { isLoopback, RequestGuard } from "./request-guard.js";
import { loadTwinFolder, robotLoadParams, type TdDocument, type TwinFolder } from "./twin-folder.js";

// node-wot's packages are CommonJS without named ESM exports
const require = createRequire(import.meta.url);
const { Servient } = require("@node-wot/core") as typeof import("@node-wot/core");
const { HttpServer } = require("@node-wot/binding-http") as typeof import("@node-wot/binding-http");

export interface EmulatorOptions {
  folder: string;
  port?: number;
  host?: string;
  /** ms between a command's arrival and the motion's start */
  latencyMs?: number;
  /** s: time constant of the first-order lag of the reported joints behind the true ones */
  lag?: number;
  /** rad (or m): standard deviation of the noise on the reported joints */
  noise?: number;
  /** fraction of the URDF velocity limits the emulated robot moves at, at speed 1 */
  velocityScale?: number;
  seed?: number;
  /** credentials required on every request (`robwot serve --auth`'s schemes) */
  auth?: AuthConfig;
  /** browser origins granted CORS and allowed to send commands */
  corsOrigins?: string[];
  /** extra names accepted in the `Host` header */
  allowedHosts?: string[];
  /** a depth camera over the cell (the `pointCloud` property); none without */
  camera?: EmulatorCamera;
}

export interface RunningEmulator {
  url: string;
  tdUrl: string;
  stop(): Promise<void>;
}

const ACCELERATION_TIME = VALUE_SCHEMAS.Acceleration["x-accelerationTime"];

type Json = Record<string, unknown>;

const message = (err: unknown): string => (err instanceof Error ? err.message : String(err));

export async function startEmulator(o: EmulatorOptions): Promise<RunningEmulator> {
  const host = o.host ?? "127.0.0.1";
  if (!isLoopback(host) && !o.auth) {
    process.emitWarning(`robwot emulate: binding ${host} without --auth exposes the robot to the network`, { code: "ROBWOT_NO_AUTH" });
  }
  const folder = loadTwinFolder(o.folder);
  const m = folder.manifest.robot;
  const latencyMs = o.latencyMs ?? 0;
  const lag = o.lag ?? 0;
  const noise = o.noise ?? 0;
  const scale = o.velocityScale ?? 1;
  const backend: LaunchedBackend = await launchBackend();
  const sim = backend.client;
  // what is running when start-up fails after it
  let controller: EmulatedController | null = null;
  let camera: DepthCamera | null = null;
  let stopServer: (() => Promise<void>) | null = null;
  try {
    const model = await sim.loadRobot(robotLoadParams(folder, EMULATED_ID));
    const names = model.controllable;
    const joints = names.map((n) => model.joints.find((j) => j.name === n)!);
    const vmax = joints.map((j) => (j.velocity > 0 ? j.velocity : 1) * scale);
    const limits = {
      names,
      lower: joints.map((j) => j.lower),
      upper: joints.map((j) => j.upper),
      vmax,
      // a joint reaches its (unscaled) velocity limit in the contract's acceleration time
      amax: vmax.map((v) => v / scale / ACCELERATION_TIME),
    };
    const robot = (controller = new EmulatedController(limits, names.map((n) => m.home?.joints[n] ?? 0), latencyMs, lag));
    const depth = (camera = o.camera ? await startCamera(sim, folder, o.camera, () => robot.joints, o.seed ?? 1) : null);

    let exposed: EmulatedThing | null = null;
    let port = 0;
    const guard = new RequestGuard({ host, port: () => port, corsOrigins: o.corsOrigins ?? [], allowedHosts: o.allowedHosts ?? [], command: { name: "emulate", serves: "the robot" } });
    const servient = new Servient();
    const http = new HttpServer({ port: o.port ?? 8081, address: host, middleware: emulatorMiddleware({ guard, auth: o.auth, thing: () => exposed }) });
    servient.addServer(http);
    const wot = await servient.start();
    port = http.getPort();
    const url = `http://${host === "0.0.0.0" || host === "::" ? "127.0.0.1" : host.includes(":") ? `[${host}]` : host}:${port}`;
    // node-wot's forms would name the machine's first network address: the address actually served
    (http as unknown as { baseUri: string }).baseUri = url;
    const closeServer = (stopServer = async (): Promise<void> => {
      const shut = servient.shutdown().catch(() => undefined);
      // keep-alive and long requests would hold close() open
      (http.getServer() as import("node:http").Server).closeAllConnections();
      await shut;
    });
    const thing = await wot.produce(thingInit(folder.td, names, { latencyMs, lag, noise, camera: depth !== null }));
    const { properties, actions } = emulatorAffordances(robot, limits, sim, noise, mulberry32(o.seed ?? 1));
    if (depth) properties.set("pointCloud", () => depth.frame());
    await thing.expose();
    // node-wot serves the Thing under a path of its own making (its title, slugified): where its forms point
    const href = String(thing.getThingDescription().properties?.["getJointPosition"]?.forms?.[0]?.href ?? "");
    const slug = new URL(href, url).pathname.split("/")[1] ?? "";
    const media: Record<string, string> = depth ? { pointCloud: POINT_CLOUD_TYPE } : {};
    exposed = { slug, td: emulatorTd(thing.getThingDescription() as unknown as Json, slug, o.auth, media), affordances: { properties, actions } };
    return {
      url,
      tdUrl: `${url}/${slug}`,
      stop: async () => {
        robot.close();
        await closeServer();
        await backend.stop();
        depth?.close();
      },
    };
  } catch (err) {
    controller?.close();
    await stopServer?.();
    await backend.stop();
    camera?.close();
    throw new Error(`robwot emulate ${o.folder}: ${message(err)}`);
  }
}

/** The emulated robot's property readers and action handlers: it moves where it is told within its own
 *  limits (its controller's inverse kinematics for a Cartesian target, not knowing the scene). */
function emulatorAffordances(robot: EmulatedController, limits: { names: string[]; lower: number[]; upper: number[] }, sim: LaunchedBackend["client"], noise: number, rand: () => number): Affordances {
  const names = limits.names;
  const record = (v: number[]): Record<string, number> => Object.fromEntries(names.map((n, i) => [n, v[i] ?? 0]));
  const answer = (end: MotionEnd): unknown => ({ status: end, joints: record(robot.reported) });
  const speedOf = (v: Json): number => (typeof v["speed"] === "number" ? v["speed"] : 1);
  const properties = new Map<string, PropertyReader>([
    ["getJointPosition", () => record(robot.reported.map((r) => r + (noise > 0 ? gaussian(rand) * noise : 0)))],
    ["motionStatus", () => robot.status],
  ]);
  /** action handlers take the input the router parsed and validated against the TD; their ServientErrors
   *  answer with their status */
  const actions = new Map<string, ActionHandler>();
  const action = (name: string, fn: (v: Json) => Promise<unknown>): void => void actions.set(name, (input) => fn(objectInput<Json>(input, name)));
  action("moveToJointPosition", async (v) => {
    // the schema names every joint within the TD's limits; the controller checks its own
    const target = names.map((n) => (v["joints"] as Record<string, number>)[n] ?? NaN);
    const k = target.findIndex((t, j) => !(t >= (limits.lower[j] ?? -Infinity) && t <= (limits.upper[j] ?? Infinity)));
    if (k >= 0) {
      const [joint, value, lower, upper] = [names[k], target[k], limits.lower[k], limits.upper[k]];
      throw servientError("E_OUT_OF_LIMITS", `joint ${joint} = ${value} is beyond its limits [${lower}, ${upper}]`, { joint, value, lower, upper });
    }
    return answer(await robot.moveTo(target, speedOf(v)));
  });
  action("moveToCartesianPosition", async (v) => {
    const p = [v["x"], v["y"], v["z"]] as [number, number, number];
    const o = v["orientation"] as { x: number; y: number; z: number; w: number } | undefined;
    // the controller's inverse kinematics, seeded with where it is; it does not know the scene
    const ik = await sim.ik({ robot: "emulated", position: p, ...(o ? { orientation: [o.x, o.y, o.z, o.w] } : {}), seed: robot.joints, collisionFree: false }).catch((err: unknown) => {
      throw fromBackendError(err);
    });
    if (ik.positionError > 1e-3) {
      throw servientError("E_UNREACHABLE", `(${p.join(", ")}) m is out of reach (${ik.positionError.toFixed(4)} m away)`, { position: p, positionError: ik.positionError });
    }
    return answer(await robot.moveTo(ik.positions, speedOf(v)));
  });
  action("jog", async (v) => {
    const velocities = v["velocities"] as Record<string, number>;
    return answer(await robot.jog(names.map((n) => velocities[n] ?? 0), v["duration"] as number));
  });
  actions.set("stop", async () => ({ stopped: robot.stop() }));
  return { properties, actions };
}

/** The camera over the cell: its scene loaded beside the emulated robot, its frames of `joints` (the true ones). */
async function startCamera(sim: LaunchedBackend["client"], folder: TwinFolder, camera: EmulatorCamera, joints: () => number[], seed: number): Promise<DepthCamera> {
  const problem = cameraProblem(camera);
  if (problem !== null) throw servientError("E_BAD_INPUT", problem, { position: camera.position, target: camera.target });
  const scene = cameraScene(folder, camera.scene);
  if (scene !== null) await loadCameraScene(sim, scene);
  return new DepthCamera(sim, camera, joints, seed);
}

/** The Thing as node-wot produces it: the twin's affordance names and data schemas, `jog`, and with a camera
 *  `pointCloud`. */
function thingInit(td: TdDocument, names: string[], o: { latencyMs: number; lag: number; noise: number; camera: boolean }): WoT.ExposedThingInit {
  // the twin's joint schema, without its forms (node-wot adds its own); read by polling (no change events)
  const { forms: _forms, observable: _observable, ...jointsSchema } = (td.properties?.["getJointPosition"] ?? {}) as Json;
  const units = (jointsSchema["properties"] ?? {}) as Record<string, { unit?: string }>;
  // a jog names the joints it moves, each at a velocity in the joint's unit per second
  const velocities = Object.fromEntries(names.map((n) => [n, { type: "number", unit: `${units[n]?.unit ?? "rad"}/s` }]));
  // what a motion answers: how it ended and the joints it reports then
  const result = {
    type: "object",
    properties: { status: { type: "string", enum: ["reached", "stopped"] }, joints: { type: "object", additionalProperties: { type: "number" } } },
    required: ["status", "joints"],
  };
  return {
    // node-wot's consumers look credentials up by the Thing's id: a stable one
    id: `${td.id ?? `urn:robwot:${td.title}`}:emulated`,
    title: `${td.title}-emulated`,
    description: `A stand-in for the physical ${td.title} (robwot emulate): moves where it is told within its own limits, latency ${o.latencyMs} ms, report lag ${o.lag} s, noise ${o.noise} rad; it does not know the scene`,
    properties: {
      getJointPosition: { ...jointsSchema, readOnly: true },
      motionStatus: {
        type: "object",
        readOnly: true,
        properties: { state: { type: "string", enum: ["idle", "moving", "stopped"] }, lastError: { type: "object" } },
      },
      ...(o.camera ? { pointCloud: POINT_CLOUD_AFFORDANCE } : {}),
    },
    actions: {
      moveToJointPosition: { input: td.actions?.["moveToJointPosition"]?.input ?? { type: "object" }, output: result },
      moveToCartesianPosition: { input: td.actions?.["moveToCartesianPosition"]?.input ?? { type: "object" }, output: result },
      jog: {
        description: "as a pendant: each named joint at its velocity (rad/s or m/s, within its limit) for duration s; a joint reaching its limit is a protective stop",
        input: {
          type: "object",
          properties: { velocities: { type: "object", properties: velocities, additionalProperties: false }, duration: { type: "number", minimum: 0, maximum: 60, unit: "s" } },
          required: ["velocities", "duration"],
          additionalProperties: false,
        },
        output: result,
      },
      stop: { output: { type: "object", properties: { stopped: { type: "boolean" } }, required: ["stopped"] } },
    },
  } as unknown as WoT.ExposedThingInit;
}
