/** Scenario entry point wrapper: run `main`, print errors clearly, set the exit code. */
import { UsageError } from "./args.js";

/** Exit once stdout and stderr have flushed (node-wot keeps sockets and timers alive after a run). */
function exitFlushed(code: number): void {
  let pending = 2;
  const done = (): void => {
    if (--pending === 0) process.exit(code);
  };
  process.stdout.write("", done);
  process.stderr.write("", done);
}

export function runScenario(name: string, usage: string, main: () => Promise<void>): void {
  main().then(
    () => exitFlushed(typeof process.exitCode === "number" ? process.exitCode : 0),
    (err: unknown) => {
      const e = err instanceof Error ? err : new Error(String(err));
      const code = (e as { code?: unknown }).code;
      console.error(`${name}: ${typeof code === "string" ? `[${code}] ` : ""}${e.message}`);
      if (err instanceof UsageError) console.error(`usage: ${usage}`);
      exitFlushed(err instanceof UsageError ? 2 : 1);
    },
  );
}
