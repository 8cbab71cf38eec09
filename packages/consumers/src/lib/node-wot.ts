/**
 * Loading node-wot (CommonJS) from our ESM code, quietly.
 *
 * `@node-wot/core` and `@node-wot/binding-http` 0.9.2 are CommonJS whose named exports Node's ESM
 * loader cannot all detect (`HttpClientFactory` is missing from `import *`), so they are loaded with
 * `createRequire`. At load time ajv prints dozens of `unknown format "iri-reference" ignored` warnings
 * (ajv 8 does not know the format); those exact lines are filtered out of `console.warn`/`console.log`, nothing else.
 */
import { createRequire } from "node:module";
import type * as NodeWotCore from "@node-wot/core";
import type * as NodeWotHttp from "@node-wot/binding-http";

const require = createRequire(import.meta.url);

const NOISE = /^unknown format "[^"]+" ignored in schema/;

function quietly<T>(load: () => T): T {
  const { warn, log } = console;
  const filter =
    (sink: (...a: unknown[]) => void) =>
    (...args: unknown[]): void => {
      if (typeof args[0] === "string" && NOISE.test(args[0])) return;
      sink(...args);
    };
  console.warn = filter(warn);
  console.log = filter(log);
  try {
    return load();
  } finally {
    console.warn = warn;
    console.log = log;
  }
}

/** Keep ajv's format warnings out of a scenario's output for the whole run (they recur on consume). */
export function silenceAjvFormatWarnings(): void {
  const { warn, log } = console;
  console.warn = (...args: unknown[]): void => {
    if (typeof args[0] === "string" && NOISE.test(args[0])) return;
    warn(...args);
  };
  console.log = (...args: unknown[]): void => {
    if (typeof args[0] === "string" && NOISE.test(args[0])) return;
    log(...args);
  };
}

export interface NodeWot {
  Servient: typeof NodeWotCore.Servient;
  HttpClientFactory: typeof NodeWotHttp.HttpClientFactory;
}

let cached: NodeWot | undefined;

export function loadNodeWot(): NodeWot {
  cached ??= quietly(() => {
    const core = require("@node-wot/core") as typeof NodeWotCore;
    const http = require("@node-wot/binding-http") as typeof NodeWotHttp;
    return { Servient: core.Servient, HttpClientFactory: http.HttpClientFactory };
  });
  return cached;
}
