/**
 * The other robots sharing this twin's world: the other twins of the same `robwot serve`
 * (`GET /robwot.json`). Each is drawn from its own twin's URDF (TD link `model`) at the base pose of its
 * twin.json, and its joints follow its own `/live` subscription.
 */
import { Group } from "three";
import type { URDFRobot } from "urdf-loader";
import { debugState, publishDebug } from "./debug.js";
import { showError } from "./errors.js";
import { xyzwToQuaternion } from "./three-frames.js";
import { fetchJson, isRecord } from "./http.js";
import { LiveClient } from "./live.js";
import type { MotionPanel } from "./motion-panel.js";
import { applyJoints, loadRobot } from "./robot.js";
import type { Stage } from "./stage.js";
import { loadTd } from "./td.js";
import { loadBasePose } from "./twin-data.js";

const ignore = (): void => undefined;

/** Slugs of the twins served next to `self`. */
async function otherSlugs(self: string): Promise<string[]> {
  const index = await fetchJson(new URL("/robwot.json", location.href).href);
  const things = isRecord(index) && Array.isArray(index["things"]) ? index["things"] : [];
  return things
    .map((t: unknown) => (isRecord(t) && typeof t["slug"] === "string" ? t["slug"] : null))
    .filter((s): s is string => s !== null && s !== self);
}

/** Resolves once every other robot is drawn or reported (the page frames the view on them too). */
export async function showOtherRobots(self: string, stage: Stage, motion: MotionPanel, liveUrl: string): Promise<Group | null> {
  const slugs = await otherSlugs(self);
  if (slugs.length === 0) return null;
  const group = new Group();
  group.name = "other robots";
  stage.add(group);
  motion.addLayer(`other robots (${slugs.length})`, true, (v) => stage.setVisible(group, v));
  await Promise.all(
    slugs.map(async (slug) => {
      try {
        const td = await loadTd(slug);
        const [{ robot, meshErrors }, pose] = await Promise.all([loadRobot(td.links.model), loadBasePose(td)]);
        for (const e of meshErrors) showError(`robot ${slug}`, e);
        robot.position.set(...pose.position);
        robot.quaternion.copy(xyzwToQuaternion(pose.orientation));
        group.add(robot);
        stage.invalidate();
        debugState.otherRobots[slug] = { base: [...pose.position], joints: {} };
        publishDebug();
        follow(slug, robot, stage, liveUrl);
      } catch (err) {
        showError(`robot ${slug} (sharing this world)`, err);
      }
    }),
  );
  return group.children.length > 0 ? group : null;
}

/** Applies the newest joint state of `slug` from its own /live subscription at display rate. */
function follow(slug: string, robot: URDFRobot, stage: Stage, liveUrl: string): void {
  let latest: Record<string, number> | null = null;
  stage.onFrame(() => {
    if (!latest) return false;
    applyJoints(robot, latest);
    const entry = debugState.otherRobots[slug];
    if (entry) entry.joints = { ...entry.joints, ...latest };
    publishDebug();
    latest = null;
    return true;
  });
  new LiveClient(liveUrl, slug, {
    joints: (q) => (latest = q),
    status: ignore,
    collision: ignore,
    scene: ignore,
    connection: ignore,
    // the twin's own live connection reports outages; only report what is specific to this robot
    error: (err) => {
      if (!/connection .* lost/.test(err.message)) showError(`live ${slug}`, err);
    },
  }).connect();
}
