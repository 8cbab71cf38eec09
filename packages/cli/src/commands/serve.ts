/** `robwot serve`: wires CLI flags to the servient (`@robwot/servient`). */
import { CliError } from "../errors.js";

export const USAGE = `Usage: robwot serve <twin-folder>... [options]
`;

export async function run(_argv: string[]): Promise<number> {
  throw new CliError("serve: the servient is not available in this build yet");
}
