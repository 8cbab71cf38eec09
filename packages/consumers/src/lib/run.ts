/** Scenario entry point wrapper: run `main`, print errors clearly, set the exit code. */
import { UsageError } from "./args.js";

export function runScenario(name: string, usage: string, main: () => Promise<void>): void {
  main().then(
    () => {
      // node-wot keeps sockets alive for a while; the scenario is done.
      process.exit(process.exitCode ?? 0);
    },
    (err: unknown) => {
      const e = err instanceof Error ? err : new Error(String(err));
      const code = (e as { code?: unknown }).code;
      console.error(`${name}: ${typeof code === "string" ? `[${code}] ` : ""}${e.message}`);
      if (err instanceof UsageError) console.error(`usage: ${usage}`);
      process.exit(err instanceof UsageError ? 2 : 1);
    },
  );
}
