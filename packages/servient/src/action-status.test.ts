import { describe, expect, it } from "vitest";
import { ActionStatusStore, type AsyncRun } from "./action-status.js";
import { ServientError } from "./errors.js";
import type { MoveHandle } from "./moves.js";

/** A move under the test's control: accepted at once, ended by `finish` / `fail`; records cancels. */
function controlled() {
  let finish!: (v: unknown) => void;
  let fail!: (e: unknown) => void;
  const done = new Promise<unknown>((res, rej) => ((finish = res), (fail = rej)));
  const state = { phase: "pending" as "pending" | "running", progress: 0, cancels: 0 };
  const handle: MoveHandle = {
    phase: () => state.phase,
    progress: () => state.progress,
    step: () => undefined,
    cancel: async () => {
      state.cancels++;
      finish({ status: "stopped" });
    },
  };
  const run: AsyncRun = (watch) => {
    watch(handle);
    return done;
  };
  return { run, state, finish, fail };
}

const href = (id: string): string => `http://h/arm/actions/moveToJointPosition/${id}`;
const idOf = (h: string): string => h.split("/").pop()!;
const A = "moveToJointPosition";

/** The status of `id`, null when the store answers 404 (unknown, expired or cancelled). */
function statusOf(store: ActionStatusStore, id: string): string | null {
  try {
    return store.get(A, id).status;
  } catch (err) {
    expect(err).toMatchObject({ status: 404, code: "E_NOT_FOUND" });
    return null;
  }
}

function clock(start = Date.parse("2026-01-01T00:00:00Z")) {
  const c = { t: start, now: () => new Date(c.t) };
  return c;
}

describe("ActionStatusStore", () => {
  it("follows the move: pending, running with progress, completed with the output and timeEnded", async () => {
    const c = clock();
    const store = new ActionStatusStore({ now: c.now });
    const m = controlled();
    const first = await store.start(A, href, m.run);
    const id = idOf(first.href);
    expect(first).toEqual({ id, status: "pending", progress: 0, href: first.href, timeRequested: "2026-01-01T00:00:00.000Z" });
    m.state.phase = "running";
    m.state.progress = 0.4;
    expect(store.get(A, id)).toMatchObject({ status: "running", progress: 0.4 });
    expect(() => store.get("moveToCartesianPosition", id)).toThrow(/unknown/);
    c.t += 1500;
    m.state.progress = 1;
    m.finish({ status: "reached" });
    await Promise.resolve();
    await Promise.resolve();
    expect(store.get(A, id)).toEqual({ ...first, status: "completed", progress: 1, output: { status: "reached" }, timeEnded: "2026-01-01T00:00:01.500Z" });
  });

  it("a refusal before acceptance rejects with the invocation's error and stores nothing", async () => {
    const store = new ActionStatusStore();
    const refused = store.start(A, href, () => Promise.reject(new ServientError(409, "E_BUSY", "busy")));
    await expect(refused).rejects.toMatchObject({ status: 409, code: "E_BUSY" });
  });

  it("a failure after acceptance: failed, with the error as RFC 7807 problem details", async () => {
    const store = new ActionStatusStore();
    const m = controlled();
    const id = idOf((await store.start(A, href, m.run)).href);
    m.fail(new ServientError(422, "E_REJECTED", "target rejected", { reasons: ["x"] }));
    await new Promise((r) => setImmediate(r));
    expect(store.get(A, id)).toMatchObject({
      status: "failed",
      error: {
        type: "https://robwot.dev/errors#E_REJECTED",
        title: "Rejected",
        status: 422,
        detail: "target rejected",
        code: "E_REJECTED",
        message: "target rejected",
        details: { reasons: ["x"] },
      },
    });
  });

  it("cancel stops a move once and deletes its status (404 naming the cancel); an ended move: nothing cancelled, stays", async () => {
    const store = new ActionStatusStore();
    const m = controlled();
    const id = idOf((await store.start(A, href, m.run)).href);
    // two DELETEs at once share the one cancel
    expect(await Promise.all([store.cancel(A, id), store.cancel(A, id)])).toEqual([true, true]);
    expect(m.state.cancels).toBe(1);
    expect(statusOf(store, id)).toBeNull();
    expect(() => store.get(A, id)).toThrow(/was cancelled at/);
    await expect(store.cancel(A, id)).rejects.toMatchObject({ status: 404 });
    await expect(store.cancel(A, "nope")).rejects.toMatchObject({ status: 404 });

    const r = controlled();
    const rid = idOf((await store.start(A, href, r.run)).href);
    r.finish({ status: "reached" });
    await new Promise((x) => setImmediate(x));
    expect(await store.cancel(A, rid)).toBe(false);
    expect(r.state.cancels).toBe(0);
    expect(statusOf(store, rid)).toBe("completed");
  });

  it("a move that reaches its target while the cancel is on its way was not cancelled: completed, kept", async () => {
    const store = new ActionStatusStore();
    const m = controlled();
    // the stop arrives as the last step ends: the move answers reached
    const run: AsyncRun = (watch) => m.run((h) => watch({ ...h, cancel: async () => m.finish({ status: "reached" }) }));
    const id = idOf((await store.start(A, href, run)).href);
    expect(await store.cancel(A, id)).toBe(false);
    expect(statusOf(store, id)).toBe("completed");
  });

  it("a relayed move the cancel cut off on the physical robot was cancelled, though the simulation had reached", async () => {
    const store = new ActionStatusStore();
    const m = controlled();
    const stopped = { status: "reached", relay: { ok: false, error: "stopped by the twin (cancelled)" } };
    const run: AsyncRun = (watch) => m.run((h) => watch({ ...h, cancel: async () => m.finish(stopped) }));
    const id = idOf((await store.start(A, href, run)).href);
    expect(await store.cancel(A, id)).toBe(true);
    expect(statusOf(store, id)).toBeNull();
  });

  it("forgets ended resources after the TTL, never a move still going", async () => {
    const c = clock();
    const store = new ActionStatusStore({ now: c.now, ttlMs: 1000 });
    const ended = controlled();
    const going = controlled();
    const e = idOf((await store.start(A, href, ended.run)).href);
    const g = idOf((await store.start(A, href, going.run)).href);
    ended.finish({ status: "reached" });
    await new Promise((x) => setImmediate(x));
    c.t += 1000;
    expect(statusOf(store, e)).toBe("completed");
    c.t += 1;
    expect(statusOf(store, e)).toBeNull();
    c.t += 1e9;
    expect(statusOf(store, g)).toBe("pending");
  });

  it("keeps the last `limit` resources: the oldest ended ones go first", async () => {
    const store = new ActionStatusStore({ limit: 3 });
    const going = controlled();
    const ids = [idOf((await store.start(A, href, going.run)).href)];
    for (let i = 0; i < 4; i++) {
      const m = controlled();
      ids.push(idOf((await store.start(A, href, m.run)).href));
      m.finish({ status: "reached" });
      await new Promise((x) => setImmediate(x));
    }
    expect(ids.map((id) => statusOf(store, id))).toEqual(["pending", null, null, "completed", "completed"]);
  });
});
