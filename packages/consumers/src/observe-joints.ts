/**
 * Scenario 3: observe the joint state live while the robot moves.
 *
 * Two observers run side by side for `--seconds` seconds:
 *  - `ws`: the servient's plain WebSocket `/live` stream (endpoint from the TD's WebSocket form),
 *  - `poll`: node-wot `observeProperty("getJointPosition")` (HTTP long-poll; node-wot 0.9.2 delivers one
 *    value per poll, so it sees fewer updates than the WebSocket).
 * Meanwhile a separate node-wot request moves the robot back and forth between two validated joint
 * targets. Once a second a line says how many updates each observer received, how many moves ended and
 * the latest joints (`--verbose`: every update, status message and move's end with its time since start;
 * `--quiet`: neither); at
 * the end the update rate of each observer, measured while the robot was moving, is printed.
 *
 *   node packages/consumers/dist/observe-joints.js [TD URL] [--seconds 5] [--speed 1] [--via ws|poll|both]
 *        [--no-move] [--quiet | --verbose] [--json]
 */
import { numberOption, speedOption, parseArgs, stringOption, UsageError } from "./lib/args.js";
import { defaultTdUrl, invoke, openSession, read, type Twin } from "./lib/connect.js";
import { fmt, fmtJoints, printJsonSummary, table } from "./lib/format.js";
import { subscribeLive, type LiveSubscription } from "./lib/live.js";
import { runScenario } from "./lib/run.js";
import { acceptedTargets, spreadTargets, type Joints } from "./lib/targets.js";
import { jointLimits } from "@robwot/core";
import type { MoveOutput } from "./lib/types.js";
import type * as WoTTypes from "wot-typescript-definitions";

const USAGE = "observe-joints [TD URL] [--seconds N] [--speed 0..1] [--via ws|poll|both] [--no-move] [--quiet | --verbose] [--json]";

/** What is printed while observing: nothing, a line a second, or every update. */
type Output = "quiet" | "summary" | "verbose";

interface Update {
  source: "ws" | "poll";
  /** seconds since the scenario started observing */
  t: number;
  joints: Joints;
}

/** Updates per second of `updates` falling inside the `[start, end]` windows (seconds). */
export function rateWithin(updates: Update[], windows: [number, number][]): { count: number; seconds: number; hz: number } {
  const seconds = windows.reduce((s, [a, b]) => s + (b - a), 0);
  const count = updates.filter((u) => windows.some(([a, b]) => u.t >= a && u.t <= b)).length;
  return { count, seconds, hz: seconds > 0 ? count / seconds : 0 };
}

interface ObserveOptions {
  url: string;
  seconds: number;
  speed: number;
  via: string;
  output: Output;
  /** move the robot back and forth (false: `--no-move`, just watch) */
  move: boolean;
  json: boolean;
}

function parseObserveArgs(argv: string[]): ObserveOptions {
  const args = parseArgs(argv, {
    seconds: "value",
    speed: "value",
    via: "value",
    quiet: "flag",
    verbose: "flag",
    "no-move": "flag",
    json: "flag",
  });
  const url = args.positional[0] ?? defaultTdUrl();
  const seconds = numberOption(args, "seconds", 5, 0.5, 3600);
  const speed = speedOption(args, 1);
  const via = stringOption(args, "via") ?? "both";
  if (!["ws", "poll", "both"].includes(via)) throw new UsageError(`--via must be ws, poll or both, got ${via}`);
  if (args.options.has("quiet") && args.options.has("verbose")) throw new UsageError("--quiet and --verbose exclude each other");
  const output: Output = args.options.has("quiet") ? "quiet" : args.options.has("verbose") ? "verbose" : "summary";
  return { url, seconds, speed, via, output, move: !args.options.has("no-move"), json: args.options.has("json") };
}

/** The observers' updates and the motion windows, timed from the start of the observation. */
class Observation {
  readonly updates: Update[] = [];
  readonly moves: [number, number][] = [];
  live: LiveSubscription | undefined;
  useWs = false;
  usePoll = false;
  /** set once the observers are being stopped: their errors then are expected */
  stopping = false;
  private t0 = performance.now();
  /** summary output: updates per observer since the last line, and when the next line is due (s) */
  private readonly counts = { ws: 0, poll: 0, moves: 0 };
  private nextLine = 1;

  constructor(private readonly output: Output) {}

  /** Observation starts now. */
  start(): void {
    this.t0 = performance.now();
  }

  now(): number {
    return (performance.now() - this.t0) / 1000;
  }

  record(source: Update["source"], joints: Joints): void {
    const u: Update = { source, t: this.now(), joints };
    this.updates.push(u);
    if (this.output === "verbose") console.log(`[+${fmt(u.t)} s] ${source.padEnd(4)} ${fmtJoints(joints)}`);
    if (this.output !== "summary") return;
    this.counts[source]++;
    if (u.t < this.nextLine) return;
    const counts = (["ws", "poll"] as const).filter((s) => this.counts[s] > 0).map((s) => `${s} ${this.counts[s]}`);
    console.log(`[+${fmt(u.t, 1)} s] updates: ${counts.join(", ")}; moves ended: ${this.counts.moves}; latest ${fmtJoints(joints)}`);
    this.counts.ws = this.counts.poll = this.counts.moves = 0;
    this.nextLine = Math.floor(u.t) + 1;
  }

  /** A move's end: a line with --verbose, counted in the next summary line by default. */
  moveEnded(line: string): void {
    this.counts.moves++;
    this.detail(line);
  }

  /** A line printed only with --verbose (a status message). */
  detail(line: string): void {
    if (this.output === "verbose") console.log(`[+${fmt(this.now())} s] ${line}`);
  }

  fail(source: string): (err: Error) => void {
    return (err) => {
      if (!this.stopping) console.error(`${source} observer error: ${err.message}`);
    };
  }
}

async function main(): Promise<void> {
  const opts = parseObserveArgs(process.argv.slice(2));
  const session = await openSession();
  const obs = new Observation(opts.output);
  try {
    const twin = await session.connect(opts.url);
    console.log(`Observing "${twin.td.title ?? "?"}" (${opts.url}) for ${opts.seconds} s via ${opts.via}`);
    const start = await read<Joints>(twin, "getJointPosition");
    const [away] = opts.move ? await acceptedTargets(twin, spreadTargets(jointLimits(twin.td), 0.4, 8), 1, start) : [start];
    if (away === undefined) throw new Error("no joint target accepted by validateJointPosition to move to");

    obs.start();
    const subscription = await startObservers(twin, obs, opts);
    const simulated = await moveBackAndForth(twin, obs, opts, start, away);
    await new Promise((r) => setTimeout(r, 200)); // let the final state of the last move arrive
    obs.stopping = true;
    await subscription?.stop();
    await obs.live?.close();
    obs.live = undefined;
    report(obs, opts, simulated);
  } finally {
    await obs.live?.close();
    await session.close();
  }
}

/** The `/live` WebSocket (unless `--via poll`) and node-wot's long-poll (unless `--via ws`, or as the fallback). */
async function startObservers(twin: Twin, obs: Observation, opts: ObserveOptions): Promise<WoTTypes.Subscription | undefined> {
  obs.usePoll = opts.via !== "ws";
  if (opts.via !== "poll") {
    try {
      obs.live = await subscribeLive(
        twin,
        (msg) => {
          if (msg.type === "joints" && msg.joints !== undefined) obs.record("ws", msg.joints);
          else if (msg.type === "status") obs.detail(`ws   status ${String(msg["state"])}`);
        },
        obs.fail("ws"),
      );
      obs.useWs = true;
      console.log(`WebSocket: ${obs.live.url}`);
    } catch (err) {
      if (opts.via === "ws") throw err;
      console.log(`no live WebSocket (${(err as Error).message}); observing by long-poll only`);
      obs.usePoll = true;
    }
  }
  if (!obs.usePoll) return undefined;
  return await twin.thing.observeProperty(
    "getJointPosition",
    (out) => {
      out.value().then((v) => obs.record("poll", v as Joints), obs.fail("poll"));
    },
    obs.fail("poll"),
  );
}

/**
 * The mover: back and forth between the start pose and `away` until time is up (with --no-move, just
 * watch: someone else, e.g. the viewer, moves the robot; rates are over the whole window). Returns the
 * seconds of motion by the twin's clock.
 */
async function moveBackAndForth(twin: Twin, obs: Observation, opts: ObserveOptions, start: Joints, away: Joints): Promise<number> {
  const deadline = opts.seconds;
  let toward: Joints = away;
  let simulated = 0;
  if (!opts.move) {
    await new Promise((r) => setTimeout(r, opts.seconds * 1000));
    obs.moves.push([0, obs.now()]);
  }
  while (opts.move && obs.now() < deadline) {
    const a = obs.now();
    const result = await invoke<MoveOutput>(twin, "moveToJointPosition", { joints: toward, speed: opts.speed });
    obs.moves.push([a, obs.now()]);
    simulated += result.duration;
    obs.moveEnded(`move ${result.status} after ${fmt(result.duration)} s`);
    toward = toward === away ? start : away;
  }
  return simulated;
}

/** Each observer's update count and rate while the robot moved; the JSON summary with `--json`. */
function report(obs: Observation, opts: ObserveOptions, simulated: number): void {
  const { updates, moves } = obs;
  const rows = (["ws", "poll"] as const)
    .filter((s) => (s === "ws" ? obs.useWs : obs.usePoll))
    .map((s) => {
      const mine = updates.filter((u) => u.source === s);
      const r = rateWithin(mine, moves);
      return { source: s, total: mine.length, ...r };
    });
  const moveCount = opts.move ? moves.length : 0;
  const open = moves.reduce((s, [a, b]) => s + b - a, 0);
  console.log(
    opts.move
      ? `\n${moveCount} moves (${fmt(simulated)} s of motion), move requests open ${fmt(open)} s of ${fmt(obs.now())} s`
      : `\nwatched ${fmt(open)} s without moving the robot`,
  );
  console.log(
    table(
      ["observer", "updates", opts.move ? "during motion" : "in window", "rate (Hz)"],
      rows.map((r) => [r.source, String(r.total), String(r.count), fmt(r.hz, 1)]),
    ),
  );
  if (opts.json) {
    const last = (src: Update["source"]): Update | null => updates.filter((u) => u.source === src).pop() ?? null;
    printJsonSummary({ moves: moveCount, motionSeconds: simulated, observers: rows, lastWs: last("ws"), lastPoll: last("poll") });
  }
}

runScenario("observe-joints", USAGE, main);
