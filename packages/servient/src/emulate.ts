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
 */
import { createRequire } from "node:module";
import { gaussian, mulberry32 } from "@robwot/core";
import { VALUE_SCHEMAS } from "@robwot/core/backend-contract";
import { launchBackend, type LaunchedBackend } from "@robwot/sim-client";
import { loadTwinFolder } from "./twin-folder.js";

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
}

export interface RunningEmulator {
  url: string;
  tdUrl: string;
  stop(): Promise<void>;
}

/** ms between two steps of the emulated controller */
const TICK_MS = 5;
const ACCELERATION_TIME = VALUE_SCHEMAS.Acceleration["x-accelerationTime"];

type Joints = Record<string, number>;

interface Motion {
  /** per tick: the next true joints, or null when the motion has ended */
  step(dt: number): number[] | null;
  /** where an ended motion leaves the joints (a line: its target), else where the last step left them */
  final?: number[];
  done: (status: "reached" | "stopped") => void;
}

const message = (err: unknown): string => (err instanceof Error ? err.message : String(err));
const sleep = (ms: number): Promise<void> => new Promise((r) => setTimeout(r, ms));

export async function startEmulator(o: EmulatorOptions): Promise<RunningEmulator> {
  const folder = loadTwinFolder(o.folder);
  const m = folder.manifest.robot;
  const latencyMs = o.latencyMs ?? 0;
  const lag = o.lag ?? 0;
  const noise = o.noise ?? 0;
  const scale = o.velocityScale ?? 1;
  const rand = mulberry32(o.seed ?? 1);
  const backend: LaunchedBackend = await launchBackend();
  const sim = backend.client;
  try {
    const model = await sim.loadRobot({
      urdf: folder.urdfPath,
      id: "emulated",
      ...(m.basePosition ? { basePosition: m.basePosition } : {}),
      ...(m.baseOrientation ? { baseOrientation: m.baseOrientation } : {}),
      ...(m.eeLink ? { eeLink: m.eeLink } : {}),
      decompose: false,
    });
    const names = model.controllable;
    const joints = names.map((n) => model.joints.find((j) => j.name === n)!);
    const vmax = joints.map((j) => (j.velocity > 0 ? j.velocity : 1) * scale);
    const amax = vmax.map((v) => v / scale / ACCELERATION_TIME);
    const lower = joints.map((j) => j.lower);
    const upper = joints.map((j) => j.upper);
    let q = names.map((n) => m.home?.joints[n] ?? 0);
    let reported = [...q];
    let motion: Motion | null = null;
    let status: { state: "idle" | "moving" | "stopped"; lastError?: { code: string; message: string } } = { state: "idle" };

    const record = (v: number[]): Joints => Object.fromEntries(names.map((n, i) => [n, v[i] ?? 0]));
    const vector = (rec: unknown): number[] => {
      if (rec === null || typeof rec !== "object") throw new Error("joints: expected an object of joint name -> value");
      const r = rec as Record<string, unknown>;
      const unknown = Object.keys(r).filter((k) => !names.includes(k));
      if (unknown.length > 0) throw new Error(`unknown joint(s) ${unknown.join(", ")}; joints are ${names.join(", ")}`);
      return names.map((n, i) => {
        const v = r[n] ?? q[i];
        if (typeof v !== "number" || !Number.isFinite(v)) throw new Error(`joint ${n}: expected a finite number`);
        return v;
      });
    };

    /** Ends the running motion (its action answers `stopped`). */
    const halt = (why?: { code: string; message: string }): boolean => {
      const running = motion;
      motion = null;
      if (running) running.done("stopped");
      status = why ? { state: "stopped", lastError: why } : { state: running ? "stopped" : status.state };
      return running !== null;
    };

    /** Starts `next` after the latency, replacing nothing: a second command while moving is refused. */
    const run = async (make: () => Omit<Motion, "done">): Promise<"reached" | "stopped"> => {
      if (motion) throw new Error("the robot is moving: stop it first");
      // until the latency has passed the robot holds still; a stop meanwhile ends the command
      const placeholder: Motion = { step: () => q, done: () => undefined };
      const result = new Promise<"reached" | "stopped">((resolve) => (placeholder.done = resolve));
      motion = placeholder;
      status = { state: "moving" };
      await sleep(latencyMs);
      if ((motion as Motion | null) === placeholder) Object.assign(placeholder, make());
      return result;
    };

    /** The straight joint-space line to `target` on a rest-to-rest trapezoid within the limits x speed. */
    const lineTo = (target: number[], speed: number): Omit<Motion, "done"> => {
      const start = [...q];
      const delta = target.map((t, i) => t - (start[i] ?? 0));
      const moving = delta.map((d) => Math.abs(d) > 0);
      const vs = Math.min(...delta.map((d, i) => (moving[i] ? ((vmax[i] ?? 1) * speed) / Math.abs(d) : Infinity)));
      const as = Math.min(...delta.map((d, i) => (moving[i] ? (amax[i] ?? 1) / Math.abs(d) : Infinity)));
      const peak = Number.isFinite(vs) ? Math.min(vs, Math.sqrt(as)) : 0;
      const ramp = peak / as;
      const duration = Number.isFinite(vs) ? (peak < vs ? 2 * ramp : 1 / vs + vs / as) : 0;
      let t = 0;
      return {
        final: target,
        step: (dt) => {
          t += dt;
          if (t >= duration) return null;
          const rise = 0.5 * as * Math.min(t, ramp) ** 2;
          const cruise = peak * Math.min(Math.max(t - ramp, 0), Math.max(0, duration - 2 * ramp));
          const tail = Math.min(Math.max(t - (duration - ramp), 0), ramp);
          const s = Math.min(1, rise + cruise + peak * tail - 0.5 * as * tail * tail);
          return start.map((a, i) => a + s * (delta[i] ?? 0));
        },
      };
    };

    // the controller's clock: true joints, then the lagged and noisy report
    let last = performance.now();
    const clock = setInterval(() => {
      const now = performance.now();
      const dt = (now - last) / 1000;
      last = now;
      const running = motion;
      if (running) {
        const next = running.step(dt);
        if (next === null) {
          if (running.final) q = [...running.final];
          motion = null;
          status = { state: "idle" };
          running.done("reached");
        } else {
          const beyond = next.findIndex((v, i) => v < (lower[i] ?? -Infinity) || v > (upper[i] ?? Infinity));
          if (beyond >= 0) {
            q = next.map((v, i) => Math.min(upper[i] ?? Infinity, Math.max(lower[i] ?? -Infinity, v)));
            halt({ code: "E_PROTECTIVE_STOP", message: `protective stop: joint ${names[beyond]} reached its limit` });
          } else {
            q = next;
          }
        }
      }
      const k = lag > 0 ? 1 - Math.exp(-dt / lag) : 1;
      reported = reported.map((r, i) => r + ((q[i] ?? r) - r) * k);
    }, TICK_MS);

    const servient = new Servient();
    const http = new HttpServer({ port: o.port ?? 8081, address: o.host ?? "127.0.0.1" });
    servient.addServer(http);
    let thing: WoT.ExposedThing;
    try {
      const wot = await servient.start();
      // node-wot's forms would name the machine's first network address: the address actually bound
      (http as unknown as { baseUri: string }).baseUri = `http://${o.host ?? "127.0.0.1"}:${http.getPort()}`;
      // the twin's joint schema, without its forms (node-wot adds its own)
      const { forms: _forms, ...jointsSchema } = (folder.td.properties?.["getJointPosition"] ?? {}) as Record<string, unknown>;
      const cartesian = (folder.td.actions?.["moveToCartesianPosition"]?.input ?? {}) as Record<string, unknown>;
      // what a motion answers: how it ended and the joints it reports then
      const result = {
        type: "object",
        properties: { status: { type: "string", enum: ["reached", "stopped"] }, joints: { type: "object", additionalProperties: { type: "number" } } },
        required: ["status", "joints"],
      };
      thing = await wot.produce({
        title: `${folder.td.title}-emulated`,
        description: `A stand-in for the physical ${folder.td.title} (robwot emulate): moves where it is told within its own limits, latency ${latencyMs} ms, report lag ${lag} s, noise ${noise} rad; it does not know the scene`,
        properties: {
          getJointPosition: { ...jointsSchema, readOnly: true, observable: true },
          motionStatus: {
            type: "object",
            readOnly: true,
            observable: true,
            properties: { state: { type: "string", enum: ["idle", "moving", "stopped"] }, lastError: { type: "object" } },
          },
        },
        actions: {
          moveToJointPosition: { input: folder.td.actions?.["moveToJointPosition"]?.input ?? { type: "object" }, output: result },
          moveToCartesianPosition: { input: cartesian, output: result },
          jog: {
            description: "as a pendant: each named joint at its velocity (rad/s or m/s, within its limit) for duration s; a joint reaching its limit is a protective stop",
            input: {
              type: "object",
              properties: { velocities: { type: "object", additionalProperties: { type: "number" } }, duration: { type: "number", minimum: 0, maximum: 60, unit: "s" } },
              required: ["velocities", "duration"],
            },
            output: result,
          },
          stop: { output: { type: "object", properties: { stopped: { type: "boolean" } }, required: ["stopped"] } },
        },
      } as unknown as WoT.ExposedThingInit);
    } catch (err) {
      clearInterval(clock);
      throw err;
    }
    const answer = (status: "reached" | "stopped"): Record<string, unknown> => ({ status, joints: record(reported) });
    const input = async (i: WoT.InteractionOutput): Promise<Record<string, unknown>> => {
      const v = await i.value();
      if (v === null || typeof v !== "object") throw new Error("expected a JSON object as input");
      return v as Record<string, unknown>;
    };
    const speedOf = (v: Record<string, unknown>): number => {
      const s = v["speed"] ?? 1;
      if (typeof s !== "number" || !(s > 0 && s <= 1)) throw new Error("speed must be in (0, 1]");
      return s;
    };
    thing.setPropertyReadHandler("getJointPosition", async () => record(reported.map((r) => r + (noise > 0 ? gaussian(rand) * noise : 0))));
    thing.setPropertyReadHandler("motionStatus", async () => status as unknown as WoT.InteractionInput);
    thing.setActionHandler("moveToJointPosition", async (i) => {
      const v = await input(i);
      const target = vector(v["joints"]);
      const outside = target.findIndex((t, k) => t < (lower[k] ?? -Infinity) || t > (upper[k] ?? Infinity));
      if (outside >= 0) throw new Error(`joint ${names[outside]} = ${target[outside]} is beyond its limits`);
      return answer(await run(() => lineTo(target, speedOf(v)))) as WoT.InteractionInput;
    });
    thing.setActionHandler("moveToCartesianPosition", async (i) => {
      const v = await input(i);
      const p = [v["x"], v["y"], v["z"]];
      if (!p.every((x) => typeof x === "number" && Number.isFinite(x))) throw new Error("x, y, z must be finite numbers (m)");
      const o = v["orientation"] as { x: number; y: number; z: number; w: number } | undefined;
      // the controller's inverse kinematics, seeded with where it is; it does not know the scene
      const ik = await sim.ik({ robot: "emulated", position: p as [number, number, number], ...(o ? { orientation: [o.x, o.y, o.z, o.w] } : {}), seed: q, collisionFree: false });
      if (ik.positionError > 1e-3) throw new Error(`(${p.join(", ")}) m is out of reach (${ik.positionError.toFixed(4)} m away)`);
      return answer(await run(() => lineTo(ik.positions, speedOf(v)))) as WoT.InteractionInput;
    });
    thing.setActionHandler("jog", async (i) => {
      const v = await input(i);
      const velocities = v["velocities"] as Record<string, unknown> | undefined;
      const duration = v["duration"];
      if (typeof duration !== "number" || !(duration >= 0 && duration <= 60)) throw new Error("duration must be in [0, 60] s");
      const rates = names.map((n, k) => {
        const r = velocities?.[n] ?? 0;
        if (typeof r !== "number" || !Number.isFinite(r)) throw new Error(`velocities.${n}: expected a number`);
        return Math.max(-(vmax[k] ?? 1), Math.min(vmax[k] ?? 1, r));
      });
      let t = 0;
      const result = await run(() => ({
        step: (dt) => {
          t += dt;
          return t >= duration ? null : q.map((x, k) => x + (rates[k] ?? 0) * dt);
        },
      }));
      return answer(result) as WoT.InteractionInput;
    });
    thing.setActionHandler("stop", async () => ({ stopped: halt() }) as WoT.InteractionInput);
    await thing.expose();
    const url = `http://${o.host ?? "127.0.0.1"}:${http.getPort()}`;
    // node-wot serves the Thing under a path of its own making: the TD URL is where its forms point
    const href = String(thing.getThingDescription().properties?.["getJointPosition"]?.forms?.[0]?.href ?? "");
    const path = new URL(href, url).pathname.replace(/\/properties\/.*$/, "");
    return {
      url,
      tdUrl: `${url}${path}`,
      stop: async () => {
        clearInterval(clock);
        halt();
        await servient.shutdown().catch(() => undefined);
        (http.getServer() as import("node:http").Server).closeAllConnections();
        await backend.stop();
      },
    };
  } catch (err) {
    await backend.stop();
    throw new Error(`robwot emulate ${o.folder}: ${message(err)}`);
  }
}
