/**
 * The backend heartbeat, one for every supervisor of a backend (the CLI's for a generation, the servient's
 * with its restarts): a `ping` every `periodMs`, each with a `deadAfterMs` deadline. The backend answers
 * ping from its event loop, which never waits for the world, so an unanswered ping means the process hung
 * or was stopped (SIGSTOP): `onDead` is called once with the reason, and what to do (kill, restart, fail
 * the calls) is the supervisor's. A closed connection is not a missed ping: its owner sees it close.
 */
import { RpcTimeoutError } from "./errors.js";

export interface HeartbeatOptions {
  /** ms between pings; a ping still pending is not doubled */
  periodMs: number;
  /** ms a ping may go unanswered before the backend counts as dead */
  deadAfterMs: number;
}

/** Starts the heartbeat; returns its stop. The timer never keeps the process alive. */
export function startHeartbeat(
  ping: (options: { timeoutMs: number }) => Promise<unknown>,
  options: HeartbeatOptions,
  onDead: (reason: string) => void,
): () => void {
  let pending = false;
  let dead = false;
  const timer = setInterval(() => {
    if (pending || dead) return;
    pending = true;
    ping({ timeoutMs: options.deadAfterMs })
      .then(
        () => undefined,
        (err: unknown) => {
          if (!(err instanceof RpcTimeoutError) || dead) return;
          dead = true;
          onDead(`no answer to ping within ${options.deadAfterMs} ms`);
        },
      )
      .finally(() => (pending = false));
  }, options.periodMs);
  timer.unref();
  return () => clearInterval(timer);
}
