import type { IncomingMessage } from "node:http";
import { describe, expect, it } from "vitest";
import { isAuthorized, type AuthConfig } from "./auth.js";

const req = (authorization?: string, url = "/"): IncomingMessage => ({ headers: authorization ? { authorization } : {}, url }) as IncomingMessage;
const b64 = (s: string): string => Buffer.from(s).toString("base64");

describe("auth", () => {
  const basic: AuthConfig = { scheme: "basic", user: "ada", password: "p:ss" };
  const bearer: AuthConfig = { scheme: "bearer", token: "t0k" };

  it.each([
    [basic, `Basic ${b64("ada:p:ss")}`, true],
    [basic, `basic ${b64("ada:p:ss")}`, true],
    [basic, `Basic ${b64("ada:wrong")}`, false],
    [basic, `Basic ${b64("eve:p:ss")}`, false],
    [basic, "Bearer t0k", false],
    [basic, undefined, false],
    [bearer, "Bearer t0k", true],
    [bearer, "bearer t0k", true],
    [bearer, "Bearer t0kk", false],
    [bearer, `Basic ${b64("a:t0k")}`, false],
  ] as [AuthConfig, string | undefined, boolean][])("%j with %s -> %s", (auth, header, ok) => {
    expect(isAuthorized(req(header), auth)).toBe(ok);
  });

  it("accepts a bearer access_token query (browser WebSockets) and everything without auth", () => {
    expect(isAuthorized(req(undefined, "/live?access_token=t0k"), bearer)).toBe(true);
    expect(isAuthorized(req(undefined, "/live?access_token=no"), bearer)).toBe(false);
    expect(isAuthorized(req(), undefined)).toBe(true);
  });
});
