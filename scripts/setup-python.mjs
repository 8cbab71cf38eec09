#!/usr/bin/env node
// Creates sim-backend/.venv with Python >= 3.11 and installs the backend (editable, with dev tools).
// Runs from `npm install` (postinstall). Idempotent: skips pip when pyproject.toml and the extras are unchanged.
// ROBWOT_EXTRAS (comma-separated, e.g. `cluster` for Ray: `robwot generate --cluster`) adds optional extras
// of sim-backend/pyproject.toml to the always-installed `dev` one.
import { execFileSync, spawnSync } from "node:child_process";
import { createHash } from "node:crypto";
import { existsSync, readFileSync, writeFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath } from "node:url";

const root = join(dirname(fileURLToPath(import.meta.url)), "..");
const backend = join(root, "sim-backend");
const venv = join(backend, ".venv");
const py = join(venv, "bin", "python");

if (process.env.ROBWOT_SKIP_PYTHON === "1") {
  console.log("[robwot] ROBWOT_SKIP_PYTHON=1: not creating the Python environment");
  process.exit(0);
}

function findPython() {
  const candidates = [process.env.ROBWOT_PYTHON, "python3.11", "python3.12", "python3"].filter(Boolean);
  for (const c of candidates) {
    const r = spawnSync(c, ["-c", "import sys; print(sys.version_info >= (3, 11))"], { encoding: "utf8" });
    if (r.status === 0 && r.stdout.trim() === "True") return c;
  }
  console.error("[robwot] error: Python >= 3.11 not found (tried " + candidates.join(", ") + "). Set ROBWOT_PYTHON.");
  process.exit(1);
}

if (!existsSync(py)) {
  const base = findPython();
  console.log(`[robwot] creating ${venv} with ${base}`);
  execFileSync(base, ["-m", "venv", venv], { stdio: "inherit" });
}
const stamp = join(venv, ".robwot-installed");
const extras = ["dev", ...(process.env.ROBWOT_EXTRAS ?? "").split(",").map((e) => e.trim()).filter(Boolean)]
  .filter((e, i, all) => all.indexOf(e) === i);
if (!extras.every((e) => /^[A-Za-z0-9_-]+$/.test(e))) {
  console.error(`[robwot] error: ROBWOT_EXTRAS=${process.env.ROBWOT_EXTRAS} is not a comma-separated list of extras`);
  process.exit(1);
}
const hash = createHash("sha256")
  .update(readFileSync(join(backend, "pyproject.toml")))
  .update(`\nextras=${extras.join(",")}`)
  .digest("hex");
if (existsSync(stamp) && readFileSync(stamp, "utf8") === hash) {
  console.log("[robwot] Python backend already installed");
} else {
  console.log(`[robwot] installing the Python backend (pybullet, numpy, scipy, websockets; extras ${extras.join(", ")})`);
  execFileSync(py, ["-m", "pip", "install", "--disable-pip-version-check", "-q", "-e", `${backend}[${extras.join(",")}]`], {
    stdio: "inherit",
  });
  writeFileSync(stamp, hash);
}
// the outer bounds' compiled kernels, once per machine (quick when numba's cache already holds them): a
// backend then loads them instead of compiling them while it serves
execFileSync(py, ["-m", "robwot_sim", "compile"], { stdio: "inherit" });
