import { mkdtempSync, readFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, beforeEach, describe, expect, it } from "vitest";
import {
  connect,
  launchBackend,
  RpcError,
  RpcTimeoutError,
  type LaunchedBackend,
  type RobotStateNotification,
  type SimClient,
} from "./index.js";

let backend: LaunchedBackend;
let sim: SimClient;
const ZERO = [0, 0, 0, 0, 0, 0, 0];

beforeAll(async () => {
  backend = await launchBackend();
  sim = backend.client;
});
afterAll(async () => {
  await backend?.stop();
});
beforeEach(async () => {
  await sim.resetWorld();
  await sim.loadRobot({ urdf: "kuka_iiwa/model.urdf", id: "kuka" });
});

async function rpcError(p: Promise<unknown>): Promise<RpcError> {
  const err = await p.then(
    (v) => {
      throw new Error(`expected an RpcError, got ${JSON.stringify(v)}`);
    },
    (e: unknown) => e,
  );
  expect(err).toBeInstanceOf(RpcError);
  return err as RpcError;
}

describe("SimClient against the real backend", () => {
  it("returns the typed robot model", async () => {
    const model = await sim.robotModel({ robot: "kuka" });
    expect(model.controllable).toHaveLength(7);
    expect(model.eeLink).toBe("lbr_iiwa_link_7");
    const j2 = model.joints.find((j) => j.name === "lbr_iiwa_joint_2");
    expect(j2?.type).toBe("revolute");
    expect(j2?.upper).toBeCloseTo(2.0944, 3);
  });

  it("sets joints, computes FK and solves IK back to the same pose", async () => {
    const q = [0.3, 0.5, -0.2, -1.0, 0.4, 0.6, 0.1];
    const set = await sim.setJointPositions({ robot: "kuka", positions: q });
    expect(set.positions).toEqual(q.map((v) => expect.closeTo(v, 9)));
    const pose = await sim.fk({ robot: "kuka" });
    expect(pose.link).toBe("lbr_iiwa_link_7");
    const ik = await sim.ik({ robot: "kuka", position: pose.position, orientation: pose.orientation });
    expect(ik.positionError).toBeLessThan(1e-3);
    const back = await sim.fk({ robot: "kuka", positions: ik.positions });
    back.position.forEach((v, i) => expect(v).toBeCloseTo(pose.position[i] as number, 3));
  });

  it("adds, moves and removes obstacles and reports contacts", async () => {
    const added = await sim.addObstacle({ name: "ball", shape: { type: "sphere", radius: 0.1 }, position: [0, 0, 0.5] });
    expect(added.name).toBe("ball");
    const hit = await sim.checkCollision({ robot: "kuka" });
    expect(hit.collisionFree).toBe(false);
    expect(hit.contacts.some((c) => c.a.body === "kuka" && c.b.body === "ball")).toBe(true);
    await sim.moveObstacle({ name: "ball", position: [2, 2, 2] });
    expect((await sim.checkCollision({ robot: "kuka" })).collisionFree).toBe(true);
    await sim.removeObstacle({ name: "ball" });
    expect((await sim.listWorld()).obstacles).toEqual([]);
  });

  it("streams robot.state notifications during a move and resolves with the MoveResult", async () => {
    const states: RobotStateNotification[] = [];
    const off = sim.on("robot.state", (s) => states.push(s));
    const result = await sim.move({ robot: "kuka", target: [0.5, ...ZERO.slice(1)], speed: 0.1 });
    off();
    expect(result.status).toBe("reached");
    // 0.5 rad at 10 % of 10 rad/s, plus the ramps of a joint that reaches its velocity limit in 0.25 s: 0.5 + 1 / 40 s
    expect(result.duration).toBeCloseTo(0.525, 6);
    expect(states.length).toBeGreaterThanOrEqual(15);
    expect(states.at(-1)?.moving).toBe(false);
    const path = await sim.checkPath({ robot: "kuka", target: ZERO });
    expect(path.collisionFree).toBe(true);
  });

  it("stops a motion from the client", async () => {
    const move = sim.move({ robot: "kuka", target: [2, ...ZERO.slice(1)], speed: 0.05 });
    await new Promise<void>((resolve) => {
      const off = sim.on("robot.state", () => {
        off();
        resolve();
      });
    });
    expect(await sim.stop({ robot: "kuka" })).toEqual({ stopped: true });
    expect((await move).status).toBe("stopped");
  });

  it("surfaces JSON-RPC errors as RpcError with code and data.code", async () => {
    const unknown = await rpcError(sim.fk({ robot: "nope" }));
    expect(unknown.rpcCode).toBe(-32001);
    expect(unknown.code).toBe("E_UNKNOWN_ROBOT");
    expect(unknown.data.code).toBe("E_UNKNOWN_ROBOT");
    expect(unknown.dataCode).toBe("E_UNKNOWN_ROBOT");
    expect(unknown.data.available).toEqual(["kuka"]);
    expect(unknown.method).toBe("robot.fk");
    const limits = await rpcError(sim.setJointPositions({ robot: "kuka", positions: [0, 3, 0, 0, 0, 0, 0] }));
    expect(limits.rpcCode).toBe(-32002);
    expect(limits.data).toMatchObject({ code: "E_OUT_OF_LIMITS", joint: "lbr_iiwa_joint_2", value: 3 });
    const params = await rpcError(sim.setJointPositions({ robot: "kuka", positions: [0, 0] }));
    expect(params.data).toMatchObject({ code: "E_INVALID_PARAMS", param: "positions" });
    const busyMove = sim.move({ robot: "kuka", target: [1, ...ZERO.slice(1)], speed: 0.1 });
    const busy = await rpcError(sim.move({ robot: "kuka", target: ZERO }));
    expect(busy.data).toEqual({ code: "E_BUSY", robot: "kuka" });
    await sim.stop({ robot: "kuka" });
    await busyMove;
    expect((await sim.ping()).version).toBeTypeOf("string");
  });

  it("times out a request and stays usable", async () => {
    const move = sim.request("robot.move", { robot: "kuka", target: [2, ...ZERO.slice(1)], speed: 0.05 }, { timeoutMs: 100 });
    const err = await move.catch((e: unknown) => e);
    expect(err).toBeInstanceOf(RpcTimeoutError);
    expect((err as RpcTimeoutError).code).toBe("E_TIMEOUT");
    expect(await sim.stop({ robot: "kuka" })).toEqual({ stopped: true });
    expect((await sim.ping()).pybullet).toBe("3.2.7");
  });

  it("warms up the workers, then generates a workspace with progress callbacks", async () => {
    const out = mkdtempSync(join(tmpdir(), "robwot-ws-"));
    const stages: string[] = [];
    expect(await sim.warmUp({ workers: 1 })).toEqual({ workers: 1 });
    const summary = await sim.generateWorkspace(
      { robot: "kuka", outDir: out, samples: 2000, seed: 3, workers: 1 },
      { onProgress: (p) => stages.push(p.stage) },
    );
    expect(summary.samples).toBe(2000);
    expect(summary.collisionFree).toBeGreaterThan(0);
    expect(new Set(stages)).toEqual(new Set(["sample", "collide", "alpha", "write"]));
    expect(readFileSync(join(out, "workspace.csv"), "utf8").trim().split("\n")).toHaveLength(2001);
  });

  it("exports a self-contained URDF", async () => {
    const out = mkdtempSync(join(tmpdir(), "robwot-export-"));
    const result = await sim.exportRobot({ robot: "kuka", outDir: out });
    expect(result.urdf).toBe("robot.urdf");
    expect(result.meshes.length).toBeGreaterThan(0);
    const urdf = readFileSync(join(out, "robot.urdf"), "utf8");
    expect(urdf).toContain("meshes/");
  });
});

describe("the backend serves only its owner", () => {
  it("a local client without the launcher's token, or a browser page, gets no connection", async () => {
    const { default: WebSocket } = await import("ws");
    const attempt = (opts: object): Promise<number | "open"> =>
      new Promise((resolve) => {
        const ws = new WebSocket(backend.url, opts);
        ws.once("open", () => {
          ws.close();
          resolve("open");
        });
        ws.once("unexpected-response", (_req, res) => resolve(res.statusCode ?? 0));
        ws.once("error", () => undefined);
      });
    expect(await attempt({})).toBe(401);
    expect(await attempt({ headers: { Authorization: "Bearer guess" } })).toBe(401);
    expect(await attempt({ origin: "http://evil.example" })).toBe(403);
    await expect(connect(backend.url, { token: "guess" })).rejects.toThrow(/401.*ROBWOT_BACKEND_TOKEN/);
    // the owner's client still works
    expect((await sim.ping()).version).toBeTruthy();
  });
});
