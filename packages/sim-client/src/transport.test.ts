import { readFileSync } from "node:fs";
import { TRANSPORT } from "@robwot/core/backend-contract";
import { describe, expect, it } from "vitest";
import { deadlineFromEnv } from "./launcher.js";
import { DEFAULT_DEADLINES } from "./supervisor.js";

const CONTRACT = JSON.parse(readFileSync(new URL("../../../sim-backend/src/robwot_sim/schemas/protocol.openrpc.json", import.meta.url), "utf8")) as {
  components: { errors: Record<string, { "x-budget"?: number }> };
};

describe("one timeout and heartbeat policy: the contract's x-transport", () => {
  it("is the supervisor's default (ROBWOT_BACKEND_DEADLINE_MS may shorten how long a ping waits)", () => {
    expect(DEFAULT_DEADLINES).toEqual({ heartbeatMs: TRANSPORT.heartbeatMs, deadAfterMs: deadlineFromEnv(TRANSPORT.deadAfterMs), restoreMs: TRANSPORT.restoreMs });
  });

  it("holds together: a short method outlasts the plan budget, a ping several heartbeats", () => {
    const budgetMs = (CONTRACT.components.errors["E_PLAN_BUDGET"]?.["x-budget"] ?? Infinity) * 1000;
    expect(TRANSPORT.requestTimeoutMs).toBeGreaterThan(budgetMs);
    expect(TRANSPORT.deadAfterMs).toBeGreaterThanOrEqual(2 * TRANSPORT.heartbeatMs);
  });
});
