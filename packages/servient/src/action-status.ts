/**
 * ActionStatus resources of asynchronous invocations (W3C WoT Profile, HTTP Basic Profile; the TD side
 * is `core/src/td/async-actions.ts`). A move invoked with `Prefer: respond-async` is started here: the
 * errors found before its acceptance (400 input, 409 busy, 503 backend down) are still the invocation's
 * answer; once accepted it gets an ActionStatus resource `<base>actions/<name>/<id>`: `pending`
 * (validation, IK, path planning), `running` (the backend streams the motion; `progress` =
 * simulated time / planned duration), then `completed` with the output the synchronous invocation
 * answers, or `failed` with its error as problem details. A DELETE (`cancel`: the `stop` path for this
 * move only, so a pending move never starts) that stopped the move deletes its resource, as the Profile
 * says (a later GET: 404 naming the cancel); one that came after the end stopped nothing: 409, the
 * resource stays as it was. The Profile's four status values are the only ones.
 *
 * Per twin the store keeps the last `limit` (64) resources and forgets ended ones `ttlMs` (10 min)
 * after they ended; a cancelled id is remembered as long (for the 404's detail only).
 */
import { randomUUID } from "node:crypto";
import type { IncomingMessage, ServerResponse } from "node:http";
import { RESPOND_ASYNC, type ActionStatusValue } from "@robwot/core";
import { toServientError, servientError } from "./errors.js";
import type { MoveHandle, MoveWatch } from "./moves.js";
import { sendJson } from "./static-files.js";

export interface ActionStatus {
  /** the last segment of `href` (the `{actionID}` of the query/cancel forms; OpenAPI links read it) */
  id: string;
  status: ActionStatusValue;
  progress: number;
  /** runProgram: the index of the step running, then the one it ended in */
  step?: number;
  output?: unknown;
  error?: Record<string, unknown>;
  href: string;
  timeRequested: string;
  timeEnded?: string;
}

interface Entry {
  id: string;
  action: string;
  href: string;
  requested: Date;
  handle: MoveHandle;
  /** set when the invocation has ended */
  end: { status: "completed" | "failed"; progress: number; step?: number; output?: unknown; error?: Record<string, unknown>; at: Date } | null;
  /** the DELETE under way: true once it stopped the move (the resource is then deleted) */
  cancelling: Promise<boolean> | null;
  /** resolves once the invocation has ended (never rejects) */
  settled: Promise<void>;
}

export interface ActionStatusOptions {
  limit?: number;
  ttlMs?: number;
  now?: () => Date;
}

/** Starts an accepted-or-refused invocation: `run` calls `watch` once the move is accepted. */
export type AsyncRun = (watch: MoveWatch) => Promise<unknown>;

export class ActionStatusStore {
  private readonly entries = new Map<string, Entry>();
  /** ids deleted by a cancel -> when, for the 404 of a later query (bounded like the entries) */
  private readonly cancelled = new Map<string, Date>();
  readonly limit: number;
  readonly ttlMs: number;
  private readonly now: () => Date;

  constructor(opts: ActionStatusOptions = {}) {
    this.limit = opts.limit ?? 64;
    this.ttlMs = opts.ttlMs ?? 10 * 60_000;
    this.now = opts.now ?? (() => new Date());
  }

  /**
   * Runs the invocation; resolves with its first ActionStatus once the move is accepted, rejects with
   * the invocation's error when it is refused before (nothing is stored then). `hrefOf(id)` is the
   * URL of the resource.
   */
  async start(action: string, hrefOf: (id: string) => string, run: AsyncRun): Promise<ActionStatus> {
    const requested = this.now();
    let accept!: (h: MoveHandle) => void;
    const accepted = new Promise<MoveHandle>((resolve) => (accept = resolve));
    const result = run((h) => accept(h));
    // refused before acceptance: the invocation's own error answers the request
    const handle = await Promise.race([accepted, result.then(() => accepted)]).catch((err: unknown) => {
      throw toServientError(err);
    });
    const id = randomUUID();
    const entry: Entry = { id, action, href: hrefOf(id), requested, handle, end: null, cancelling: null, settled: Promise.resolve() };
    entry.settled = result.then(
      (output) => {
        const step = handle.step();
        entry.end = { status: "completed", progress: handle.progress(), ...(step !== undefined ? { step } : {}), output, at: this.now() };
      },
      (err: unknown) => {
        const e = toServientError(err);
        entry.end = { status: "failed", progress: handle.progress(), error: { ...e.problem() }, at: this.now() };
      },
    );
    this.prune(true);
    this.entries.set(id, entry);
    return this.view(entry);
  }

  /** The current ActionStatus of `id` under `action`; a 404 error when unknown, expired or cancelled. */
  get(action: string, id: string): ActionStatus {
    return this.view(this.entry(action, id));
  }

  /**
   * cancelaction: stops the invocation and, once it has ended, deletes its resource (true). False when
   * nothing was stopped: it had ended before (or reached its target while the stop was on its way);
   * its resource stays. A 404 error when unknown.
   */
  async cancel(action: string, id: string): Promise<boolean> {
    const e = this.entry(action, id);
    if (e.end && !e.cancelling) return false;
    // concurrent DELETEs share the one cancel and its answer
    e.cancelling ??= this.stop(e, id);
    return e.cancelling;
  }

  private async stop(e: Entry, id: string): Promise<boolean> {
    await e.handle.cancel();
    await e.settled;
    // a cancel that came after the target was reached stopped nothing
    if (this.reached(e)) return false;
    this.entries.delete(id);
    this.cancelled.set(id, this.now());
    return true;
  }

  /** The move got all the way: the simulation reached the target and a relayed command (if any) ended
   *  on the physical robot; a cancel then stopped nothing. A relay the cancel cut off is not "all the way". */
  private reached(e: Entry): boolean {
    const out = e.end?.status === "completed" ? (e.end.output as { status?: unknown; relay?: { ok?: unknown } } | null) : null;
    return out?.status === "reached" && out.relay?.ok !== false;
  }

  private entry(action: string, id: string): Entry {
    this.prune();
    const e = this.entries.get(id);
    if (e && e.action === action) return e;
    const at = this.cancelled.get(id);
    const why = at
      ? `was cancelled at ${at.toISOString()} (a cancelled invocation's ActionStatus is deleted)`
      : `is unknown, or forgotten (the last ${this.limit} are kept, ended ones for ${this.ttlMs / 1000} s)`;
    throw servientError("E_NOT_FOUND", `ActionStatus ${id} of ${action} ${why}`, { action, id, ...(at ? { cancelled: at.toISOString() } : {}) });
  }

  private view(e: Entry): ActionStatus {
    const base = { id: e.id, href: e.href, timeRequested: e.requested.toISOString() };
    if (!e.end) {
      const step = e.handle.step();
      return { status: e.handle.phase(), progress: e.handle.progress(), ...(step !== undefined ? { step } : {}), ...base };
    }
    const { status, progress, step, output, error, at } = e.end;
    return { status, progress, ...(step !== undefined ? { step } : {}), ...(output !== undefined ? { output } : {}), ...(error ? { error } : {}), ...base, timeEnded: at.toISOString() };
  }

  /** Forgets ended resources older than the TTL; with `room`, also the oldest ended ones until one more fits. */
  private prune(room = false): void {
    const now = this.now().getTime();
    for (const [id, e] of this.entries) if (e.end && now - e.end.at.getTime() > this.ttlMs) this.entries.delete(id);
    for (const [id, at] of this.cancelled) if (now - at.getTime() > this.ttlMs || this.cancelled.size > this.limit) this.cancelled.delete(id);
    for (const [id, e] of this.entries) {
      if (!room || this.entries.size < this.limit) break;
      if (e.end) this.entries.delete(id);
    }
  }
}

/** RFC 7240 preferences of a request (`Prefer: respond-async, return=representation`): token -> value. */
export function preferences(req: IncomingMessage): Map<string, string> {
  const raw = req.headers.prefer;
  const out = new Map<string, string>();
  for (const pref of (Array.isArray(raw) ? raw.join(",") : (raw ?? "")).split(",")) {
    const [token = "", value = ""] = (pref.split(";")[0] ?? "").split("=").map((x) => x.trim().replace(/^"|"$/g, ""));
    if (token) out.set(token.toLowerCase(), value.toLowerCase());
  }
  return out;
}

/** The asynchronous invocation's answer: 201, `Location`, `Preference-Applied`, the ActionStatus. */
export async function respondAsync(res: ServerResponse, store: ActionStatusStore, name: string, base: string, invoke: AsyncRun): Promise<void> {
  const status = await store.start(name, (id) => new URL(`actions/${encodeURIComponent(name)}/${id}`, base).href, invoke);
  res.setHeader("Location", status.href);
  res.setHeader("Preference-Applied", RESPOND_ASYNC);
  sendJson(res, 201, status);
}

/**
 * `GET` (queryaction) and `DELETE` (cancelaction) on `<base>actions/<name>/<id>`: GET 200 with the
 * ActionStatus; DELETE 204 once the move has stopped (its resource deleted), 409 when it had already
 * ended (nothing stopped); 404 for an unknown, expired or cancelled id.
 */
export async function actionStatusRoute(req: IncomingMessage, res: ServerResponse, store: ActionStatusStore, name: string, id: string): Promise<void> {
  if (req.method !== "DELETE") return sendJson(res, 200, store.get(name, id));
  if (!(await store.cancel(name, id))) {
    const { status } = store.get(name, id);
    throw servientError("E_NOT_CANCELLABLE", `${name} ${id} had already ended (${status}): nothing was cancelled; its ActionStatus stays`, { action: name, id, status });
  }
  res.writeHead(204);
  res.end();
}
