/** `robwot demo` reuses its twin, and says when an earlier session's calibration applies to it. */
import { mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, expect, it } from "vitest";
import { runCli } from "./cli-run.js";

const work = mkdtempSync(join(tmpdir(), "robwot-demo-"));
afterAll(() => rmSync(work, { recursive: true, force: true }));

it("reuses the demo twin and names a calibration written into it", async () => {
  const out = join(work, "demo");
  const first = await runCli(["demo", "--out", out, "--samples", "1000", "--no-serve"]);
  expect(first.code, first.stderr).toBe(0);
  const again = await runCli(["demo", "--out", out, "--no-serve"]);
  expect(again.stdout).toMatch(/reusing the demo twin/);
  expect(again.stdout).not.toMatch(/calibration/);
  writeFileSync(join(out, "calibration.json"), JSON.stringify({ version: 1, transform: { scale: 1, rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], translation: [0.1, 0, 0] } }));
  const calibrated = await runCli(["demo", "--out", out, "--no-serve"]);
  expect(calibrated.code, calibrated.stderr).toBe(0);
  expect(calibrated.stdout).toMatch(/robwot: note: .*calibration\.json \(written by a calibrate action on \d{4}-\d\d-\d\dT[^)]*\) applies: the TD's Cartesian frame is the calibrated one \(delete the file, or --regenerate, to start uncalibrated\)/);
}, 120_000);
