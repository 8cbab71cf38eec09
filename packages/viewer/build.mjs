// Build the browser bundle: type-check (tsc --noEmit, DOM lib), then bundle src/main.ts with esbuild
// into dist/ together with index.html and viewer.css. Everything is local: no CDN, works offline.
import { spawnSync } from "node:child_process";
import { copyFileSync, mkdirSync, rmSync } from "node:fs";
import { createRequire } from "node:module";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";
import { build } from "esbuild";

const here = dirname(fileURLToPath(import.meta.url));
const require = createRequire(import.meta.url);
const dist = join(here, "dist");

const tsc = require.resolve("typescript/bin/tsc");
const check = spawnSync(process.execPath, [tsc, "-p", join(here, "tsconfig.json")], { stdio: "inherit" });
if (check.status !== 0) {
  console.error("viewer: type check failed");
  process.exit(check.status ?? 1);
}

rmSync(dist, { recursive: true, force: true });
mkdirSync(dist, { recursive: true });
await build({
  entryPoints: [join(here, "src/main.ts")],
  outfile: join(dist, "viewer.js"),
  bundle: true,
  format: "esm",
  platform: "browser",
  target: ["es2022"],
  minify: true,
  sourcemap: true,
  legalComments: "linked",
  logLevel: "warning",
});
for (const file of ["index.html", "viewer.css"]) copyFileSync(join(here, file), join(dist, file));
console.log(`viewer: bundled into ${dist}`);
