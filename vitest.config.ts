import { defineConfig } from "vitest/config";

export default defineConfig({
  test: {
    include: ["packages/*/src/**/*.test.ts", "tests/**/*.test.ts"],
    testTimeout: 120_000,
    hookTimeout: 180_000,
    // Tests start real Python backends and servients; two cores: keep files sequential-ish.
    fileParallelism: true,
    maxWorkers: 2,
    // backends started by the tests check every result against their contract (E_INTERNAL otherwise)
    env: { ROBWOT_CHECK_RESULTS: "1" },
    // ajv's "unknown format ... ignored" lines, dropped as the CLI drops them (every other line kept)
    setupFiles: ["packages/cli/src/quiet-console.setup.ts"],
  },
});
