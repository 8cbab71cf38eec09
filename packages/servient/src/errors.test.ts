/** The HTTP status of every backend error code comes from the contract: none falls through to 500. */
import { ERRORS, type ErrorCode } from "@robwot/core/backend-contract";
import { BackendDownError, BackendStartError, ConnectionClosedError, RpcError, RpcTimeoutError } from "@robwot/sim-client";
import { describe, expect, it } from "vitest";
import { fromBackendError, servientError, SERVIENT_STATUS, statusOf } from "./errors.js";

/** Codes only a bug of ours can produce (the servient sent a malformed request or the backend failed). */
const OUR_BUGS = new Set<ErrorCode>(["E_PARSE", "E_INVALID_REQUEST", "E_METHOD_NOT_FOUND", "E_INTERNAL"]);

describe("fromBackendError", () => {
  it.each(Object.entries(ERRORS) as [ErrorCode, (typeof ERRORS)[ErrorCode]][])("%s answers the contract's status", (code, e) => {
    const err = fromBackendError(new RpcError(e.rpcCode, `failed with ${code}`, { code, file: "robot.urdf" }, "robot.load"));
    expect(err.status).toBe(e.httpStatus);
    expect(err.code).toBe(code);
    expect(err.message).toBe(`failed with ${code}`);
    // a client's input is a 4xx; a Ray cluster that cannot be reached is a bad gateway, not our bug
    if (OUR_BUGS.has(code)) expect(err.status).toBe(500);
    else if (code === "E_CLUSTER") expect(err.status).toBe(502);
    else expect(err.status).toBeLessThan(500);
  });

  it("carries the error's fields as details, without repeating the code", () => {
    const err = fromBackendError(new RpcError(-32003, "bad URDF", { code: "E_URDF", file: "a.urdf", line: 3 }, "robot.load"));
    expect(err.status).toBe(422);
    expect(err.details).toEqual({ file: "a.urdf", line: 3 });
  });

  it.each([
    ["a closed connection", new ConnectionClosedError("closed (code 1006)", "ws://127.0.0.1:1"), 503, "E_BACKEND_DOWN"],
    ["a backend that did not start", new BackendStartError("no ready line", ""), 503, "E_BACKEND_DOWN"],
    ["no answer in time", new RpcTimeoutError("robot.fk", 1000), 504, "E_BACKEND_TIMEOUT"],
    ["the supervisor's backend down", new BackendDownError("simulation backend is restarting; retry shortly"), 503, "E_BACKEND_DOWN"],
    ["anything else thrown", new Error("socket hang up"), 503, "E_BACKEND_DOWN"],
  ])("%s answers %i", (_what, thrown, status, code) => {
    const err = fromBackendError(thrown);
    expect(err.status).toBe(status);
    expect(err.code).toBe(code);
  });
});

describe("servientError", () => {
  it("gives each code one status: the contract's for the backend's codes, the servient's own for the rest", () => {
    const overlap = Object.keys(SERVIENT_STATUS).filter((c) => Object.hasOwn(ERRORS, c));
    expect(overlap).toEqual([]);
    expect(servientError("E_PATH_ESCAPE", "x").status).toBe(ERRORS.E_PATH_ESCAPE.httpStatus);
    expect(servientError("E_LOOP", "x").status).toBe(508);
    for (const [code, { httpStatus }] of Object.entries(ERRORS)) expect(statusOf(code as ErrorCode)).toBe(httpStatus);
  });
});
