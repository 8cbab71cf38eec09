/**
 * One twin exposed by the servient: its node-wot Thing, its `Mover`, its `Follower` (with `--follow`), its
 * property readers and action handlers, and the `ServedThing` the router serves it from.
 */
import { targetBounds, type Bounds } from "@robwot/core";
import type { BackendSupervisor } from "@robwot/sim-client";
import { ActionStatusStore } from "./action-status.js";
import { actionHandlers } from "./actions.js";
import type { AuthConfig } from "./auth.js";
import { Follower, FOLLOW_RATE, type FollowOptions } from "./follow.js";
import type { ServedThing } from "./http-middleware.js";
import { Mover } from "./moves.js";
import { propertyReaders, registerProperties, sseSource } from "./properties.js";
import type { RelayMap } from "./relay-map.js";
import type { Relay } from "./relay.js";
import { produceInit, servedTd } from "./thing-td.js";
import type { TdDocument } from "./twin-folder.js";
import type { Twin } from "./twin.js";
import type { WorkspaceChecks } from "./workspace-checks.js";
import type { SceneRecord } from "./scene-record.js";

/** What every twin of the servient shares. */
export interface ExposeEnv {
  wot: typeof WoT;
  backend: BackendSupervisor;
  world: SceneRecord;
  realtime: number;
  auth: AuthConfig | undefined;
  /** the servient's base and live URLs (known once it listens) */
  url: string;
  liveUrl: string;
  relay: Relay | null;
  relayMap: RelayMap | null;
  /** the physical robot's TD URL to follow, null: none */
  followUrl: string | null;
  follow: Omit<FollowOptions, "map" | "rate"> & { rate?: number };
  /** the twin's TD changed (a calibration): registered again */
  changed(id: string): void;
}

export interface ExposedTwin {
  served: ServedThing;
  mover: Mover;
  follower: Follower | null;
}

export async function exposeTwin(env: ExposeEnv, slug: string, twin: Twin, checks: WorkspaceChecks | null): Promise<ExposedTwin> {
  const bounds: Bounds | null = twin.folder.workspace ? targetBounds(twin.folder.workspace) : null;
  let cached: TdDocument | null = null;
  const td = (): TdDocument => (cached ??= servedTd(twin.folder.td, { url: env.url, slug, liveUrl: env.liveUrl, auth: env.auth, frames: twin.frames, bounds }));
  const thing = await env.wot.produce(produceInit(twin.folder.td));
  const mover = new Mover(env.backend, twin, checks, env.realtime, env.relay);
  const follower = env.followUrl
    ? new Follower(env.wot as never, env.followUrl, twin, env.backend, { ...env.follow, rate: env.follow.rate ?? FOLLOW_RATE.default, map: env.relayMap }, () => twin.emit("physical"))
    : null;
  if (follower) twin.follow(() => follower.view());
  const described = (kind: "properties" | "actions"): string[] => Object.keys(twin.folder.td[kind] ?? {});
  const properties = propertyReaders(described("properties"), twin, env.world, () => follower?.view() ?? null);
  registerProperties(thing, twin, env.world, properties);
  const actions = actionHandlers(described("actions"), {
    backend: env.backend,
    twin,
    mover,
    world: env.world,
    realtime: env.realtime,
    onCalibrated: () => {
      cached = null;
      env.changed(String(td().id ?? ""));
    },
  });
  await thing.expose();
  const served: ServedThing = {
    slug,
    dir: twin.folder.dir,
    urdfName: twin.folder.manifest.robot.urdf,
    td,
    actionInput: (name) => {
      const a = td().actions?.[name];
      return a ? ((a.input as object | undefined) ?? undefined) : null;
    },
    observe: (kind, name) => sseSource(twin, env.world, properties, kind, name),
    affordances: { properties, actions },
    statuses: new ActionStatusStore(),
  };
  return { served, mover, follower };
}
