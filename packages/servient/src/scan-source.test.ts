/**
 * The scan source in-process: which obstacles a frame adds, moves or removes (`scan-changes.ts`), and a
 * `ScanSource` applying frames through a fake backend and a fake world (a frame refused keeps the last
 * good scene and is the fault shown).
 */
import { describe, expect, it } from "vitest";
import type { BackendSupervisor } from "@robwot/sim-client";
import type { Quaternion, Vec3 } from "@robwot/core";
import { contains, grown, scanChanges, type ScanBox } from "./scan-changes.js";
import { Outbound } from "./outbound.js";
import { ScanSource, sniffExtension, STILL_MS, type ScanWorld } from "./scan-source.js";

const I: Quaternion = { x: 0, y: 0, z: 0, w: 1 };
const box = (name: string, position: Vec3, size: Vec3 = [0.1, 0.1, 0.2], orientation: Quaternion = I): ScanBox => ({ name, position, size, orientation });
const yaw = (a: number): Quaternion => ({ x: 0, y: 0, z: Math.sin(a / 2), w: Math.cos(a / 2) });

describe("scanChanges", () => {
  let n = 0;
  const fresh = (): string => `scan-${++n}`;

  it("adds a new box grown by the hysteresis, and changes nothing while the next frames' boxes lie inside it", () => {
    const first = scanChanges([], [box("object-1", [0.5, 0, 0.1])], 0.005, 0.5, fresh);
    expect(first.add).toHaveLength(1);
    expect(first.add[0]!.size).toEqual([0.11, 0.11, 0.21].map((v) => expect.closeTo(v, 12)));
    const world = first.add;
    // the same object seen again, 2 mm off and 1 mm larger: inside the grown box
    const again = scanChanges(world, [box("object-1", [0.502, 0.001, 0.1], [0.101, 0.1, 0.2])], 0.005, 0.5, fresh);
    expect(again).toEqual({ add: [], move: [], remove: [] });
  });

  it("moves the obstacle of an object that moved, and removes the one of an object gone", () => {
    const world = [grown(box("scan-a", [0.5, 0, 0.1]), 0.005), grown(box("scan-b", [0.2, 0.3, 0.1]), 0.005)];
    const c = scanChanges(world, [box("object-1", [0.5, 0.2, 0.1], [0.1, 0.1, 0.2], yaw(0.3))], 0.005, 0.5, fresh);
    expect(c.move).toEqual([{ name: "scan-a", position: [0.5, 0.2, 0.1], orientation: yaw(0.3) }]);
    expect(c.remove).toEqual(["scan-b"]);
    expect(c.add).toEqual([]);
  });

  it("adds rather than moves when no obstacle of that size is within reach", () => {
    const world = [grown(box("scan-a", [0.5, 0, 0.1]), 0.005)];
    const far = scanChanges(world, [box("object-1", [1.5, 0, 0.1])], 0.005, 0.5, fresh);
    expect(far.add).toHaveLength(1);
    expect(far.remove).toEqual(["scan-a"]);
    const bigger = scanChanges(world, [box("object-1", [0.5, 0.1, 0.1], [0.3, 0.1, 0.2])], 0.005, 0.5, fresh);
    expect(bigger.add).toHaveLength(1);
    expect(bigger.move).toEqual([]);
  });

  it("contains: a box turned inside a larger one, not one poking out", () => {
    const outer = box("o", [0, 0, 0], [0.2, 0.2, 0.2]);
    expect(contains(outer, box("i", [0, 0, 0], [0.1, 0.1, 0.1], yaw(0.7)))).toBe(true);
    expect(contains(outer, box("i", [0.06, 0, 0], [0.1, 0.1, 0.1]))).toBe(false);
  });
});

it("sniffs a frame's format from its bytes", () => {
  expect(sniffExtension(Buffer.from("ply\nformat ascii 1.0\n"))).toBe(".ply");
  expect(sniffExtension(Buffer.from("# .PCD v0.7\nVERSION 0.7\n"))).toBe(".pcd");
  expect(sniffExtension(Buffer.from("0.1 0.2 0.3\n"))).toBe(".xyz");
});

describe("ScanSource.applyFrame", () => {
  function rig(answers: (() => unknown)[], now: () => number = () => 1e9): { source: ScanSource; calls: string[]; warnings: string[] } {
    const calls: string[] = [];
    const warnings: string[] = [];
    const sim = {
      sceneFromScan: async () => {
        const next = answers.shift()!;
        return next();
      },
    };
    const backend = { sim } as unknown as BackendSupervisor;
    const world: ScanWorld = {
      addObstacle: async (_b, o) => void calls.push(`add ${o.name}`),
      moveObstacle: async (_b, p) => void calls.push(`move ${p.name} ${p.position.join(",")}`),
      removeObstacle: async (_b, name) => void calls.push(`remove ${name}`),
    };
    const source = new ScanSource({ source: "/nowhere", noise: 0.005, periodMs: 1000 }, backend, world, new Outbound(), (m) => warnings.push(m), now);
    return { source, calls, warnings };
  }
  const scan = (position: Vec3): unknown => ({
    obstacles: [{ name: "object-1", shape: { type: "box", size: [0.1, 0.1, 0.2] }, position, orientation: [0, 0, 0, 1] }],
    supports: [], objects: [], points: {}, seconds: 0,
  });

  it("adds, keeps, moves; a refused frame keeps the last good scene and is the fault until a frame succeeds", async () => {
    const refused = (): unknown => {
      throw new Error("cut.ply: truncated");
    };
    const { source, calls, warnings } = rig([() => scan([0.5, 0, 0.1]), () => scan([0.501, 0, 0.1]), refused, refused, () => scan([0.5, 0.3, 0.1])]);
    const frame = Buffer.from("ply\n");
    await source.applyFrame(frame);
    await source.applyFrame(frame);
    expect(calls).toEqual(["add scan-1"]);
    await source.applyFrame(frame);
    await source.applyFrame(frame);
    expect(calls).toEqual(["add scan-1"]);
    expect(source.status().fault).toContain("truncated");
    expect(warnings).toHaveLength(1); // said once per kind of failure
    await source.applyFrame(frame);
    expect(calls).toEqual(["add scan-1", "move scan-1 0.5,0.3,0.1"]);
    expect(source.status()).toMatchObject({ frames: 3, fault: null, obstacles: ["scan-1"] });
    source.stop();
  });

  it("skips a frame arriving while a robot moves or just after, and one built while it moved", async () => {
    let clock = 0;
    let moveDuringBuild = false;
    const answers = [() => scan([0.5, 0, 0.1]), () => scan([0.5, 0, 0.1])];
    const { source, calls } = rig(
      answers.map((a) => () => {
        if (moveDuringBuild) source.moved();
        return a();
      }),
      () => clock,
    );
    source.moved(); // at t = 0
    clock = STILL_MS - 1;
    source.offer(Buffer.from("ply\n")); // too soon after the move: never built
    expect(source.status().skipped).toBe(1);
    clock = STILL_MS + 1;
    moveDuringBuild = true;
    await source.applyFrame(Buffer.from("ply\n")); // the robot moved while it was built: not applied
    expect(calls).toEqual([]);
    expect(source.status().skipped).toBe(2);
    clock = 2 * STILL_MS + 2;
    moveDuringBuild = false;
    await source.applyFrame(Buffer.from("ply\n"));
    expect(calls).toEqual(["add scan-1"]);
    source.stop();
  });
});
