/**
 * ajv (inside the TD validator and node-wot) prints `unknown format "iri-reference" ignored in schema ...`
 * dozens of times. Those lines say nothing to a CLI user: drop exactly them, pass everything else through.
 */
const NOISE = /unknown format ".*" ignored/;

export function silenceAjvFormatNoise(): void {
  for (const method of ["log", "warn", "error", "info"] as const) {
    const original = console[method].bind(console);
    console[method] = (...args: unknown[]): void => {
      const first = args[0];
      if (typeof first === "string" && NOISE.test(first)) return;
      original(...args);
    };
  }
}
