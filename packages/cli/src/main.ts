#!/usr/bin/env node
/**
 * `robwot` entry point: dispatches to one module per command and turns every failure into
 * `robwot: error: <message>` on stderr with a non-zero exit code. Its own imports are light (`--version`,
 * `--help`); a command's modules, and the packages behind them, load only when that command runs.
 */
import { runCleanups, wasInterrupted } from "./lifecycle.js";
import { silenceAjvFormatNoise } from "./quiet-console.js";
import { exampleHelp } from "./examples.js";
import { VERSION } from "./version.js";

const COMMANDS: Record<string, () => Promise<{ run(argv: string[]): Promise<number>; USAGE: string }>> = {
  generate: () => import("./commands/generate.js"),
  serve: () => import("./commands/serve.js"),
  demo: () => import("./commands/demo.js"),
  openapi: () => import("./commands/openapi.js"),
  asyncapi: () => import("./commands/asyncapi.js"),
  emulate: () => import("./commands/emulate.js"),
  scene: () => import("./commands/scene.js"),
};

const HELP = `robwot ${VERSION}: turn a robot arm's URDF into a Web of Things digital twin

Usage:
  robwot generate <robot.urdf | example-name> [options]   build a twin folder (TD, URDF, workspace)
  robwot serve <twin-folder>... [options]                 serve twins as node-wot Things
  robwot demo                                             generate the bundled demo twin and serve it
  robwot openapi <twin-folder> [--out FILE] [--base URL]  the OpenAPI 3.0 document of a twin's HTTP API
  robwot asyncapi <twin-folder> [--out FILE] [--base URL] the AsyncAPI 3.0 document of its streams
  robwot emulate <twin-folder> [options]                  a stand-in physical robot for the twin to relay to
  robwot scene from-scan <cloud>... [options]             a conservative scene file from point clouds
  robwot <command> --help                                 options of a command

Example robots:
${exampleHelp()}
`;

async function main(argv: string[]): Promise<number> {
  silenceAjvFormatNoise();
  // `robwot ... | head`: a closed pipe is not an error worth a stack trace
  process.stdout.on("error", (err: NodeJS.ErrnoException) => {
    if (err.code === "EPIPE") return; // keep going: clean-up must still run
    throw err;
  });
  const [command, ...rest] = argv;
  if (command === undefined || command === "help" || command === "--help" || command === "-h") {
    process.stdout.write(HELP);
    return command === undefined ? 2 : 0;
  }
  if (command === "--version" || command === "-v") {
    process.stdout.write(`${VERSION}\n`);
    return 0;
  }
  const load = COMMANDS[command];
  if (!load) {
    process.stderr.write(`robwot: error: unknown command "${command}" (valid: ${Object.keys(COMMANDS).join(", ")})\n`);
    return 2;
  }
  const mod = await load();
  if (rest.includes("--help") || rest.includes("-h")) {
    process.stdout.write(mod.USAGE);
    return 0;
  }
  return mod.run(rest);
}

let code: number;
try {
  code = await main(process.argv.slice(2));
} catch (err) {
  // After Ctrl-C the pending request fails because the backend was stopped: not worth a message.
  if (wasInterrupted()) {
    await runCleanups();
    process.exit(130);
  }
  const { describeError } = await import("./errors.js");
  const { message, exitCode } = describeError(err);
  process.stderr.write(`robwot: error: ${message}\n`);
  if (process.env["ROBWOT_DEBUG"] && err instanceof Error && err.stack) process.stderr.write(`${err.stack}\n`);
  code = exitCode;
}
await runCleanups();
process.exit(code);
