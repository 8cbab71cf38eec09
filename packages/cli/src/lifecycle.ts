/**
 * Clean-up on the way out: stop the backend, remove temporary folders. Runs the registered actions (in
 * reverse order) on normal completion, on errors, and on SIGINT/SIGTERM, each at most once.
 */

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
  for (const sig of ["SIGINT", "SIGTERM"] as const) {
    process.on(sig, () => {
      if (interrupted) process.exit(130);
      interrupted = true;
      process.stderr.write(`\nrobwot: ${sig === "SIGINT" ? "interrupted" : "terminated"}, cleaning up\n`);
      const force = setTimeout(() => process.exit(130), 5000);
      force.unref();
      void runCleanups().finally(() => process.exit(130));
    });
  }
}
