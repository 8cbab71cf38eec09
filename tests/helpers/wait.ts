/**
 * Waiting in the end-to-end tests: for a condition, never for a time. A deadline only bounds a failure
 * (so a slow machine makes a test slower, never red); a test that needs a real gap says why at the call.
 */

/** A real-time gap. Only for a gap the test itself creates (load, a hung peer); never to wait for a result. */
export const sleep = (ms: number): Promise<void> => new Promise((r) => setTimeout(r, ms));

export interface WaitOptions {
  /** bounds a failure only; generous so that a loaded machine is slow, not red */
  timeoutMs?: number;
  /** between two probes */
  intervalMs?: number;
  /** what is awaited, for the error message */
  what?: string;
  /** a probe that throws counts as "not yet" (a page between two loads); the last error is reported */
  ignoreErrors?: boolean;
}

/**
 * Probes until `probe` returns a truthy value (or a promise of one) and returns it; throws after
 * `timeoutMs` with the last value seen. A probe that throws fails the wait at once, unless `ignoreErrors`.
 */
export async function waitFor<T>(probe: () => T | Promise<T>, opts: WaitOptions = {}): Promise<NonNullable<T>> {
  const { timeoutMs = 30_000, intervalMs = 25, what = "the condition", ignoreErrors = false } = opts;
  const end = Date.now() + timeoutMs;
  for (;;) {
    let last: string;
    try {
      const v = await probe();
      if (v) return v as NonNullable<T>;
      last = JSON.stringify(v)?.slice(0, 300) ?? String(v);
    } catch (err) {
      if (!ignoreErrors) throw err;
      last = String(err);
    }
    if (Date.now() > end) throw new Error(`${what} did not hold within ${timeoutMs} ms (last: ${last})`);
    await sleep(intervalMs);
  }
}

/** `p`, or a rejection naming `what` after `timeoutMs` (a bound on a failure only). */
export async function within<T>(p: Promise<T>, what: string, timeoutMs = 30_000): Promise<T> {
  let timer: NodeJS.Timeout | undefined;
  const late = new Promise<never>((_, reject) => {
    timer = setTimeout(() => reject(new Error(`${what}: not within ${timeoutMs} ms`)), timeoutMs);
  });
  try {
    return await Promise.race([p, late]);
  } finally {
    clearTimeout(timer);
  }
}
