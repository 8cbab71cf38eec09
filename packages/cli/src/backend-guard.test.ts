import type { AddressInfo } from "node:net";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { WebSocketServer } from "ws";
import type { BackendGuard as Guard } from "./backend-guard.js";

/** A backend that answers until a generation starts, then hangs (as a SIGSTOPped one does): no ping answered. */
function hangingBackend(): { server: WebSocketServer; url: () => string } {
  const server = new WebSocketServer({ host: "127.0.0.1", port: 0 });
  let hung = false;
  const results: Record<string, unknown> = { ping: { pybulletData: "/data" }, "world.list": { robots: [], obstacles: [], objects: [] } };
  server.on("connection", (ws) => {
    ws.on("message", (data: Buffer) => {
      const { id, method } = JSON.parse(data.toString()) as { id: number; method: string };
      if (method === "workspace.generate") hung = true;
      if (!hung) ws.send(JSON.stringify({ jsonrpc: "2.0", id, result: results[method] ?? {} }));
    });
  });
  return { server, url: () => `ws://127.0.0.1:${(server.address() as AddressInfo).port}` };
}

const backend = hangingBackend();
const saved = process.env["ROBWOT_BACKEND_DEADLINE_MS"];
let BackendGuard: typeof Guard;

beforeAll(async () => {
  process.env["ROBWOT_BACKEND_DEADLINE_MS"] = "300"; // read when sim-client is first imported
  ({ BackendGuard } = await import("./backend-guard.js"));
});
afterAll(async () => {
  if (saved === undefined) delete process.env["ROBWOT_BACKEND_DEADLINE_MS"];
  else process.env["ROBWOT_BACKEND_DEADLINE_MS"] = saved;
  await new Promise((r) => backend.server.close(r));
});

describe("BackendGuard", () => {
  it("hands out the generated client; a backend that stops answering fails every call with the reason", async () => {
    const guard = await BackendGuard.open(backend.url());
    expect(guard.pybulletData).toBe("/data");
    const stopped = { code: "E_BACKEND", message: "the simulation backend stopped answering (no answer to ping within 300 ms)" };
    // a long method has no request deadline of its own: the heartbeat ends it
    await expect(guard.sim.generateWorkspace({ robot: "r", outDir: "/nowhere" })).rejects.toMatchObject(stopped);
    await expect(guard.sim.listWorld()).rejects.toMatchObject(stopped);
    await guard.close();
  });
});
