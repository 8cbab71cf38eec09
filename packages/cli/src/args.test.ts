import { parseArgs } from "node:util";
import { describe, expect, it } from "vitest";
import { usageError } from "./args.js";

const OPTIONS = { samples: { type: "string" }, seed: { type: "string" }, scene: { type: "string" } } as const;

function errorOf(args: string[]): string {
  try {
    parseArgs({ args, options: OPTIONS, allowPositionals: true, strict: true });
  } catch (err) {
    return usageError(err, "generate", Object.keys(OPTIONS)).message;
  }
  throw new Error("parseArgs accepted " + args.join(" "));
}

describe("usageError", () => {
  it("names a mistyped option on one line with the closest valid one", () => {
    expect(errorOf(["kuka_iiwa", "--sampels", "10"])).toBe("unknown option --sampels (did you mean --samples?; see robwot generate --help)");
  });
  it("guesses from a prefix", () => {
    expect(errorOf(["--sce", "a.json"])).toBe("unknown option --sce (did you mean --scene?; see robwot generate --help)");
  });
  it("names an unknown option without a guess when nothing is close", () => {
    expect(errorOf(["--frobnicate"])).toBe("unknown option --frobnicate (see robwot generate --help)");
  });
  it("keeps other parseArgs errors on one line", () => {
    const m = errorOf(["--samples"]);
    expect(m).not.toContain("\n");
    expect(m).toContain("--samples");
    expect(m).toContain("(see robwot generate --help)");
  });
});
