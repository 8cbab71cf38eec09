/**
 * A deadline on a promise the caller cannot cancel (a node-wot request): past `ms` the returned promise
 * rejects with a `DeadlineError` naming what was awaited, whatever the original does later. The original
 * keeps running; whoever owns it decides what a late answer means (the follower never sends a second
 * request while one is still pending).
 */

export class DeadlineError extends Error {
  override name = "DeadlineError";
  readonly code = "E_DEADLINE";

  constructor(
    readonly what: string,
    readonly ms: number,
  ) {
    super(`${what}: no answer within ${ms} ms`);
  }
}

/** `p`, or a `DeadlineError` once `ms` have passed without it settling. */
export function withDeadline<T>(p: Promise<T>, ms: number, what: string): Promise<T> {
  return new Promise<T>((resolve, reject) => {
    const timer = setTimeout(() => reject(new DeadlineError(what, ms)), ms);
    p.then(
      (v) => {
        clearTimeout(timer);
        resolve(v);
      },
      (err: unknown) => {
        clearTimeout(timer);
        reject(err instanceof Error ? err : new Error(String(err)));
      },
    );
  });
}
