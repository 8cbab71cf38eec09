/**
 * Scenario 5: an asynchronous move, chosen from the TD alone (README "Asynchronous moves").
 *
 * Picks a joint target inside the TD's limits that validateJointPosition accepts, then invokes
 * moveToJointPosition through the form that states `Prefer: respond-async` (`htv:headers`; node-wot
 * sends a form's headers when asked for it by `formIndex`): the answer is the ActionStatus, at once. It
 * polls the status through the `queryaction` form (its `{actionID}` filled in), printing the progress;
 * with `--cancel-at F` it cancels through the `cancelaction` form once the progress passes F (204: the
 * move has stopped and, as the WoT Profile says, its ActionStatus is deleted: a query then answers 404)
 * and checks that the robot then stands still.
 *
 *   node packages/consumers/dist/async-move.js [TD URL] [--speed 0.3] [--fraction 0.3] [--cancel-at 0..1] [--json]
 */
import type { FormLike } from "@robwot/core";
import { jointLimits } from "@robwot/core";
import { numberOption, speedOption, parseArgs } from "./lib/args.js";
import { authHeaders, defaultTdUrl, openSession, read, type Twin } from "./lib/connect.js";
import { fmt, fmtJoints, printJsonSummary } from "./lib/format.js";
import { runScenario } from "./lib/run.js";
import { acceptedTargets, spreadTargets } from "./lib/targets.js";

const USAGE = "async-move [TD URL] [--speed 0..1] [--fraction 0..0.9] [--cancel-at 0..1] [--json]";
const ACTION = "moveToJointPosition";

interface ActionStatus {
  status: "pending" | "running" | "completed" | "failed";
  progress: number;
  href: string;
  output?: { status: string; joints: Record<string, number> };
  error?: { code: string; detail: string };
  timeRequested: string;
  timeEnded?: string;
}

const ops = (f: FormLike): string[] => (Array.isArray(f.op) ? f.op : f.op === undefined ? [] : [f.op]);
const prefersAsync = (f: FormLike): boolean =>
  Array.isArray(f["htv:headers"]) &&
  (f["htv:headers"] as Record<string, unknown>[]).some((h) => String(h["htv:fieldName"]).toLowerCase() === "prefer" && h["htv:fieldValue"] === "respond-async");

/** The asynchronous invokeaction form's index and the queryaction / cancelaction forms, from the TD. */
function asyncForms(twin: Twin): { index: number; query: FormLike; cancel: FormLike } {
  const forms = twin.td.actions?.[ACTION]?.forms ?? [];
  const index = forms.findIndex((f) => ops(f).includes("invokeaction") && prefersAsync(f));
  const query = forms.find((f) => ops(f).includes("queryaction"));
  const cancel = forms.find((f) => ops(f).includes("cancelaction"));
  if (index < 0 || !query || !cancel) throw new Error(`${twin.url}: ${ACTION} has no asynchronous forms (Prefer: respond-async, queryaction, cancelaction)`);
  return { index, query, cancel };
}

async function request(twin: Twin, form: FormLike, id: string, fallbackMethod: string): Promise<Response> {
  const url = form.href.replace("{actionID}", encodeURIComponent(id));
  const res = await fetch(url, { method: String(form["htv:methodName"] ?? fallbackMethod), headers: authHeaders(twin.auth) });
  if (!res.ok) throw new Error(`${String(form["htv:methodName"] ?? fallbackMethod)} ${url} answered ${res.status}: ${(await res.text()).slice(0, 300)}`);
  return res;
}

const sleep = (ms: number): Promise<void> => new Promise((r) => setTimeout(r, ms));

async function main(): Promise<void> {
  const args = parseArgs(process.argv.slice(2), { speed: "value", fraction: "value", "cancel-at": "value", json: "flag" });
  const url = args.positional[0] ?? defaultTdUrl();
  const speed = speedOption(args, 0.3);
  const fraction = numberOption(args, "fraction", 0.3, 0, 0.9);
  const cancelAt = args.options.has("cancel-at") ? numberOption(args, "cancel-at", 0.5, 0, 1) : null;
  const session = await openSession();
  try {
    const twin = await session.connect(url);
    const forms = asyncForms(twin);
    const joints = await read<Record<string, number>>(twin, "getJointPosition");
    const [target] = await acceptedTargets(twin, spreadTargets(jointLimits(twin.td), fraction, 8), 1, joints, (t, reasons) =>
      console.log(`candidate ${fmtJoints(t, 2)} rejected: ${reasons.join("; ")}`),
    );
    if (target === undefined) throw new Error("no candidate joint target was accepted by validateJointPosition");

    console.log(`${ACTION} (asynchronous: form ${forms.index}) speed=${speed}: ${fmtJoints(target)}`);
    // node-wot 0.9.2 gives a `formIndex` invocation a fresh HTTP client, and the credentials only when
    // no client is cached yet: the asynchronous invocation is the first interaction of its own
    // ConsumedThing
    const fresh = await session.connect(url);
    // the action is `synchronous: true` (a plain POST answers the move's result) and node-wot 0.9.2 then
    // checks every answer against the action's output schema: the 201's ActionStatus is read as bytes
    const out = await fresh.thing.invokeAction(ACTION, { joints: target, speed }, { formIndex: forms.index });
    if (!out) throw new Error(`${ACTION}: no answer`);
    const accepted = JSON.parse(Buffer.from(await out.arrayBuffer()).toString("utf8")) as ActionStatus;
    const id = accepted.href.split("/").pop() ?? "";
    console.log(`accepted: ${accepted.status}, status resource ${accepted.href}`);
    const seen: { status: string; progress: number }[] = [];
    let cancelled = false;
    let st = accepted;
    const deadline = Date.now() + 120_000;
    while (!cancelled && (st.status === "pending" || st.status === "running")) {
      if (Date.now() > deadline) throw new Error(`${accepted.href} still ${st.status} after 120 s`);
      await sleep(50);
      st = (await (await request(twin, forms.query, id, "GET")).json()) as ActionStatus;
      const last = seen.at(-1);
      if (!last || last.status !== st.status || st.progress - last.progress >= 0.1) {
        seen.push({ status: st.status, progress: st.progress });
        console.log(`  ${st.status} ${fmt(st.progress * 100, 0)} %`);
      }
      if (cancelAt !== null && !cancelled && st.status === "running" && st.progress >= cancelAt) {
        const del = await request(twin, forms.cancel, id, "DELETE");
        const gone = await fetch(forms.query.href.replace("{actionID}", encodeURIComponent(id)), { headers: authHeaders(twin.auth) });
        cancelled = true;
        console.log(`  cancelled at ${fmt(st.progress * 100, 0)} % (DELETE ${del.status}; the status resource then answers ${gone.status})`);
        if (del.status !== 204 || gone.status !== 404) process.exitCode = 1;
      }
    }
    console.log(`final: ${cancelled ? "cancelled" : st.status}${st.output ? ` (move ${st.output.status})` : ""}${st.error ? ` (${st.error.code}: ${st.error.detail})` : ""}`);
    const final = await read<Record<string, number>>(twin, "getJointPosition");
    // a cancelled move has ended: the robot stands still
    await sleep(300);
    const later = await read<Record<string, number>>(twin, "getJointPosition");
    const still = Object.keys(final).every((k) => final[k] === later[k]);
    console.log(`joints: ${fmtJoints(final)}${still ? " (standing still)" : " (still moving!)"}`);
    if (!(cancelAt === null ? st.status === "completed" : cancelled) || !still) process.exitCode = 1;
    if (args.options.has("json")) printJsonSummary({ target, accepted, seen, final: st, cancelled, joints: final, still });
  } finally {
    await session.close();
  }
}

runScenario("async-move", USAGE, main);
