import { describe, expect, it } from "vitest";
import { describeExit } from "@robwot/sim-client";
import { BackendGuard } from "./backend-guard.js";

describe("a backend that crashes", () => {
  it("is reported with the signal and Python's fault report, not as a closed socket", async () => {
    const guard = await BackendGuard.open();
    try {
      const pid = guard.pid;
      expect(pid).toBeGreaterThan(0);
      process.kill(pid!, "SIGSEGV"); // as a crash in native code ends it
      const failed = await guard.sim.listWorld().then(
        () => new Error("the call was answered"),
        (err: unknown) => guard.explain(err),
      );
      expect(failed).toMatchObject({ code: "E_BACKEND" });
      expect((failed as Error).message).toMatch(/^the simulation backend was killed by SIGSEGV; its last words on stderr:\nFatal Python error: Segmentation fault/);
    } finally {
      await guard.close();
    }
  }, 30_000);

  it("describes an exit by code and the last lines it wrote, or by the crash report onwards", () => {
    expect(describeExit({ code: 1, signal: null }, "a\nb\n\nc\nd\ne\nf\n")).toBe("exited with code 1; its last words on stderr:\nb\nc\nd\ne\nf");
    expect(describeExit({ code: null, signal: "SIGKILL" }, "")).toBe("was killed by SIGKILL");
    const report = "noise\nFatal Python error: Segmentation fault\n\nThread 0x1 (most recent call first):\n  File \"x.py\", line 3 in f\n";
    expect(describeExit({ code: null, signal: "SIGSEGV" }, report)).toBe(
      'was killed by SIGSEGV; its last words on stderr:\nFatal Python error: Segmentation fault\nThread 0x1 (most recent call first):\n  File "x.py", line 3 in f',
    );
  });
});
