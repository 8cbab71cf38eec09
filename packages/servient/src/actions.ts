/**
 * Action handlers. Inputs come parsed and schema-validated from the HTTP middleware (request context);
 * handlers re-check what the schema cannot (speed > 0, unknown joints, quaternion norm, calibration
 * geometry) and throw ServientErrors that the middleware answers as JSON with their status.
 */
import type { ObstacleMoveParams } from "@robwot/sim-client";
import type { BackendSupervisor } from "@robwot/sim-client";
import { calibrate, type CalibrateInput } from "./calibrate.js";
import { badInput, backendDown } from "./errors.js";
import { ASYNC_ACTIONS } from "@robwot/core";
import type { CartesianInput, JointInput, Mover, MoveWatch, ProgramInput } from "./moves.js";
import { recordErrors, requestContext } from "./request-context.js";
import type { SceneObstacle } from "./twin-folder.js";
import type { Twin } from "./twin.js";
import type { World } from "./world.js";

function objectInput<T>(v: unknown): T {
  if (v === null || typeof v !== "object" || Array.isArray(v)) throw badInput("expected a JSON object as input", { got: v ?? null });
  return v as T;
}

async function inputOf<T>(input: WoT.InteractionOutput): Promise<T> {
  const ctx = requestContext.getStore();
  return objectInput<T>(ctx?.hasBody ? ctx.body : await input.value());
}

export interface ActionDeps {
  backend: BackendSupervisor;
  twin: Twin;
  mover: Mover;
  world: World;
  onCalibrated(): void;
}

/** An asynchronous invocation of a move action (`action-status.ts`): the input as validated by the
 *  HTTP middleware, `watch` called once the move is accepted. */
export type AsyncAction = (input: unknown, watch: MoveWatch) => Promise<unknown>;

/** Registers every action handler with node-wot; returns the move actions' asynchronous invocations
 *  (`ASYNC_ACTIONS`), which run the same code as their synchronous handlers. */
export function registerActions(thing: WoT.ExposedThing, d: ActionDeps): Map<string, AsyncAction> {
  const needBackend = (name: string): void => {
    if (!d.backend.isUp) throw backendDown("simulation backend is restarting; retry shortly", { action: name });
  };
  const on = <T>(name: string, fn: (input: T) => Promise<unknown> | unknown, needsBackend = true): void => {
    thing.setActionHandler(
      name,
      recordErrors(async (input: WoT.InteractionOutput) => {
        if (needsBackend) needBackend(name);
        const value = name === "stop" ? undefined : await inputOf<T>(input);
        return (await fn(value as T)) as WoT.InteractionInput;
      }),
    );
  };
  const moves: Record<string, (input: never, watch?: MoveWatch) => Promise<unknown>> = {
    moveToJointPosition: (i: JointInput, w?: MoveWatch) => d.mover.moveJoints(i, w),
    moveToCartesianPosition: (i: CartesianInput, w?: MoveWatch) => d.mover.moveCartesian(i, w),
  };
  const asyncActions = new Map<string, AsyncAction>();
  for (const [name, move] of Object.entries(moves)) {
    on(name, (i: never) => move(i));
    if (!ASYNC_ACTIONS.includes(name)) continue;
    asyncActions.set(name, async (input, watch) => {
      needBackend(name);
      return move(objectInput<never>(input), watch);
    });
  }
  on<JointInput>("validateJointPosition", (i) => d.mover.validateJoints(i));
  on<CartesianInput>("validateCartesianPosition", (i) => d.mover.validateCartesian(i));
  on<ProgramInput>("validateProgram", (i) => d.mover.validateProgram(i));
  // a stop is never refused, not even while the backend restarts or hangs: it cancels a pending move,
  // stops the physical robot at once and reports the simulation's and the physical robot's outcomes
  on("stop", () => d.mover.stop(), false);
  on<CalibrateInput>(
    "calibrate",
    (i) => {
      const r = calibrate(d.twin, i);
      d.onCalibrated();
      return r;
    },
    false,
  );
  on<SceneObstacle>("addObstacle", (i) => d.world.addObstacle(d.backend, i));
  on<ObstacleMoveParams>("moveObstacle", (i) => d.world.moveObstacle(d.backend, i));
  on<{ name: string }>("removeObstacle", (i) => d.world.removeObstacle(d.backend, i.name));
  return asyncActions;
}
