/**
 * Clean-up on the way out: stop the backend, remove temporary folders. Runs the registered actions (in
 * reverse order) on normal completion, on errors, and on SIGINT/SIGTERM/SIGHUP, each at most once;
 * the process then exits with 128 + the signal number.
 */
import { TRANSPORT } from "@robwot/core/backend-contract";

type Cleanup = () => void | Promise<void>;

const actions: Cleanup[] = [];
let installed = false;
let interrupted = false;

/** Registers a clean-up action; returns a function that unregisters it (after it was done normally). */
export function onCleanup(fn: Cleanup): () => void {
  installSignalHandlers();
  actions.push(fn);
  return () => {
    const i = actions.indexOf(fn);
    if (i >= 0) actions.splice(i, 1);
  };
}

/** Runs and forgets every registered action, newest first; errors are reported, not thrown. */
export async function runCleanups(): Promise<void> {
  while (actions.length > 0) {
    const fn = actions.pop();
    try {
      await fn?.();
    } catch (err) {
      process.stderr.write(`robwot: warning: clean-up failed: ${(err as Error).message}\n`);
    }
  }
}

export function wasInterrupted(): boolean {
  return interrupted;
}

function installSignalHandlers(): void {
  if (installed) return;
  installed = true;
  const codes = { SIGHUP: 129, SIGINT: 130, SIGTERM: 143 } as const;
  for (const sig of ["SIGINT", "SIGTERM", "SIGHUP"] as const) {
    process.on(sig, () => {
      const code = codes[sig];
      if (interrupted) process.exit(code);
      interrupted = true;
      process.stderr.write(`\nrobwot: ${sig === "SIGINT" ? "interrupted" : sig === "SIGHUP" ? "hung up" : "terminated"}, cleaning up\n`);
      // an own backend gets the contract's stop timeout before SIGKILL: leave as long again for the clean-ups
      // after it, and as long for anything stuck
      const force = setTimeout(() => process.exit(code), 3 * TRANSPORT.stopTimeoutMs);
      force.unref();
      void runCleanups().finally(() => process.exit(code));
    });
  }
}
