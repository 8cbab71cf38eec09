/**
 * The servient's record of the cell's devices in the shared world: the conveyors (each with its state and
 * speed now) and the sensors of the twins' scenes (the first twin naming one wins, as for obstacles). The
 * `SceneRecord` replays them with the scene on a fresh backend (`sceneParts`), so a restarted backend has
 * every belt back in the state it was in; `conveyorSet` keeps a belt's state as `conveyor.set` answered it.
 */
import type { Conveyor, ConveyorSpec, SensorSpec } from "@robwot/sim-client";
import type { SceneDoc } from "./twin-folder.js";

type Json = Record<string, unknown>;

const isObject = (v: unknown): v is Json => typeof v === "object" && v !== null && !Array.isArray(v);

export class CellRecord {
  /** the conveyors by name, in the scene files' order, each as a scene document states it (state now) */
  readonly conveyors = new Map<string, ConveyorSpec>();
  /** the sensors by name */
  readonly sensors = new Map<string, SensorSpec>();

  /** The conveyors and sensors of the twins' scene documents (`twin-folder.ts` checked they are arrays). */
  constructor(scenes: readonly SceneDoc[]) {
    for (const scene of scenes) {
      for (const c of (scene.conveyors ?? []) as unknown[]) {
        if (isObject(c) && typeof c["name"] === "string" && !this.conveyors.has(c["name"])) this.conveyors.set(c["name"], c as unknown as ConveyorSpec);
      }
      for (const s of (scene.sensors ?? []) as unknown[]) {
        if (!isObject(s) || typeof s["name"] !== "string" || this.sensors.has(s["name"])) continue;
        // a listing's sensor carries its reading: not part of a scene document
        const { reading: _reading, ...spec } = s;
        this.sensors.set(s["name"], spec as unknown as SensorSpec);
      }
    }
  }

  /** What the scene document given to `world.loadScene` holds of the cell (nothing when it has none). */
  sceneParts(): { conveyors?: ConveyorSpec[]; sensors?: SensorSpec[] } {
    return {
      ...(this.conveyors.size > 0 ? { conveyors: [...this.conveyors.values()] } : {}),
      ...(this.sensors.size > 0 ? { sensors: [...this.sensors.values()] } : {}),
    };
  }

  /** A belt as `conveyor.set` (or `cell.list`) answered it: its state and speed replayed from now on. */
  conveyorSet(c: Conveyor): void {
    const spec = this.conveyors.get(c.name);
    if (spec) this.conveyors.set(c.name, { ...spec, state: c.state, speed: c.speed });
  }
}
