/**
 * Scenario 3: observe the joint state live while the robot moves.
 *
 * Two observers run side by side for `--seconds` seconds:
 *  - `ws`: the servient's plain WebSocket `/live` stream (endpoint from the TD's WebSocket form),
 *  - `poll`: node-wot `observeProperty("getJointPosition")` (HTTP long-poll; node-wot 0.9.2 delivers one
 *    value per poll, so it sees fewer updates than the WebSocket).
 * Meanwhile a separate node-wot request moves the robot back and forth between two validated joint
 * targets. Each update is printed with its time since start; at the end the update rate of each
 * observer, measured while the robot was moving, is printed.
 *
 *   node packages/consumers/dist/observe-joints.js [TD URL] [--seconds 5] [--speed 1] [--via ws|poll|both]
 *        [--no-move] [--quiet] [--json]
 */
import { numberOption, speedOption, parseArgs, stringOption, UsageError } from "./lib/args.js";
import { defaultTdUrl, invoke, openSession, read } from "./lib/connect.js";
import { fmt, fmtJoints, printJsonSummary, table } from "./lib/format.js";
import { subscribeLive, type LiveSubscription } from "./lib/live.js";
import { runScenario } from "./lib/run.js";
import { acceptedTargets, spreadTargets, type Joints } from "./lib/targets.js";
import { jointLimits } from "@robwot/core";
import type { MoveResult } from "./lib/types.js";

const USAGE = "observe-joints [TD URL] [--seconds N] [--speed 0..1] [--via ws|poll|both] [--no-move] [--quiet] [--json]";

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

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), {
    seconds: "value",
    speed: "value",
    via: "value",
    quiet: "flag",
    "no-move": "flag",
    json: "flag",
  });
  const url = args.positional[0] ?? defaultTdUrl();
  const seconds = numberOption(args, "seconds", 5, 0.5, 3600);
  const speed = speedOption(args, 1);
  const via = stringOption(args, "via") ?? "both";
  if (!["ws", "poll", "both"].includes(via)) throw new UsageError(`--via must be ws, poll or both, got ${via}`);
  const quiet = args.options.has("quiet");

  const session = await openSession();
  const updates: Update[] = [];
  const moves: [number, number][] = [];
  let live: LiveSubscription | undefined;
  let t0 = performance.now();
  const now = (): number => (performance.now() - t0) / 1000;
  const record = (source: Update["source"], joints: Joints): void => {
    const u: Update = { source, t: now(), joints };
    updates.push(u);
    if (!quiet) console.log(`[+${fmt(u.t)} s] ${source.padEnd(4)} ${fmtJoints(joints)}`);
  };
  let stopping = false;
  const fail = (source: string) => (err: Error) => {
    if (!stopping) console.error(`${source} observer error: ${err.message}`);
  };

  try {
    const twin = await session.connect(url);
    console.log(`Observing "${twin.td.title ?? "?"}" (${url}) for ${seconds} s via ${via}`);
    const start = await read<Joints>(twin, "getJointPosition");
    const move = !args.options.has("no-move");
    const [away] = move ? await acceptedTargets(twin, spreadTargets(jointLimits(twin.td), 0.4, 8), 1, start) : [start];
    if (away === undefined) throw new Error("no joint target accepted by validateJointPosition to move to");

    t0 = performance.now(); // observation starts now
    let usePoll = via !== "ws";
    let useWs = false;
    if (via !== "poll") {
      try {
        live = await subscribeLive(
          twin,
          (msg) => {
            if (msg.type === "joints" && msg.joints !== undefined) record("ws", msg.joints);
            else if (msg.type === "status" && !quiet) console.log(`[+${fmt(now())} s] ws   status ${String(msg["state"])}`);
          },
          fail("ws"),
        );
        useWs = true;
        console.log(`WebSocket: ${live.url}`);
      } catch (err) {
        if (via === "ws") throw err;
        console.log(`no live WebSocket (${(err as Error).message}); observing by long-poll only`);
        usePoll = true;
      }
    }
    const subscription =
      usePoll
        ? await twin.thing.observeProperty(
            "getJointPosition",
            (out) => {
              out.value().then((v) => record("poll", v as Joints), fail("poll"));
            },
            fail("poll"),
          )
        : undefined;

    // The mover: back and forth between the start pose and `away` until time is up (with --no-move,
    // just watch: someone else, e.g. the viewer, moves the robot; rates are over the whole window).
    const deadline = seconds;
    let toward: Joints = away;
    let simulated = 0; // s of motion, by the twin's clock
    if (!move) {
      await new Promise((r) => setTimeout(r, seconds * 1000));
      moves.push([0, now()]);
    }
    while (move && now() < deadline) {
      const a = now();
      const result = await invoke<MoveResult>(twin, "moveToJointPosition", { joints: toward, speed });
      moves.push([a, now()]);
      simulated += result.duration;
      if (!quiet) console.log(`[+${fmt(now())} s] move ${result.status} after ${fmt(result.duration)} s`);
      toward = toward === away ? start : away;
    }
    await new Promise((r) => setTimeout(r, 200)); // let the final state of the last move arrive
    stopping = true;
    await subscription?.stop();
    await live?.close();
    live = undefined;

    const rows = (["ws", "poll"] as const)
      .filter((s) => (s === "ws" ? useWs : usePoll))
      .map((s) => {
        const mine = updates.filter((u) => u.source === s);
        const r = rateWithin(mine, moves);
        return { source: s, total: mine.length, ...r };
      });
    const moveCount = move ? moves.length : 0;
    const open = moves.reduce((s, [a, b]) => s + b - a, 0);
    console.log(
      move
        ? `\n${moveCount} moves (${fmt(simulated)} s of motion), move requests open ${fmt(open)} s of ${fmt(now())} s`
        : `\nwatched ${fmt(open)} s without moving the robot`,
    );
    console.log(
      table(
        ["observer", "updates", move ? "during motion" : "in window", "rate (Hz)"],
        rows.map((r) => [r.source, String(r.total), String(r.count), fmt(r.hz, 1)]),
      ),
    );
    if (args.options.has("json")) {
      const last = (src: Update["source"]): Update | null => updates.filter((u) => u.source === src).pop() ?? null;
      printJsonSummary({ moves: moveCount, motionSeconds: simulated, observers: rows, lastWs: last("ws"), lastPoll: last("poll") });
    }
  } finally {
    await live?.close();
    await session.close();
  }
}

runScenario("observe-joints", USAGE, main);
