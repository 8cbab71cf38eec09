/**
 * One twin's page: loads the TD, model, scene, point cloud and workspace surface, wires the control
 * panel to the TD's HTTP forms and the live WebSocket to the model.
 */
import { Mesh, MeshBasicMaterial, type Object3D, SphereGeometry } from "three";
import type { URDFRobot } from "urdf-loader";
import { activeCalibration, invertCalibration, type SimilarityTransform, TWIN_FILES } from "@robwot/core/browser";
import { CartesianPanel } from "./cartesian-panel.js";
import { ProgramPanel } from "./program-panel.js";
import { Commander } from "./commander.js";
import { debugState, publishDebug } from "./debug.js";
import { DivergencePlot } from "./divergence-plot.js";
import { showError, showNotice } from "./errors.js";
import { xyzwToQuaternion } from "./three-frames.js";
import { isRecord } from "./http.js";
import { JointPanel } from "./joint-panel.js";
import { LiveClient } from "./live.js";
import { MotionPanel } from "./motion-panel.js";
import { showOtherRobots } from "./other-robots.js";
import { PhysicalRobotLayer } from "./physical-robot.js";
import { applyJoints, highlightLink, loadRobot } from "./robot.js";
import { ObjectsPlot } from "./objects-plot.js";
import { ObstacleLayer } from "./scene-layer.js";
import { Stage, TargetMarker } from "./stage.js";
import { loadTd, readProperty, type TwinTd } from "./td.js";
import { loadBasePose, loadCloud, loadReachability, loadScene, loadSurface } from "./twin-data.js";

const HIGHLIGHT_MS = 3000;

/** What the page's parts share; each field is set by the one part named in its comment. */
interface PageState {
  /** the loaded model (the robot load), null until then */
  robot: URDFRobot | null;
  /** joints to draw on the next frame (the live stream, the first state read), null once drawn */
  latest: Record<string, number> | null;
  /** the TCP position the twin last reported (the TD's frame): the program panel's example starts there */
  tcpNow: { x: number; y: number; z: number } | null;
  /** x_real = s·R·x_virtual + t (the calibration property): Cartesian inputs are in the real frame, the 3D view in the virtual one */
  calibration: SimilarityTransform | null;
}

interface Controls {
  motion: MotionPanel;
  joints: JointPanel;
  cartesian: CartesianPanel;
  showCalibration: (c: unknown) => void;
}

type Point = { x: number; y: number; z: number };

export async function showTwin(slug: string, view: HTMLElement, content: HTMLElement): Promise<void> {
  debugState.thing = slug;
  publishDebug();
  const td = await loadTd(slug);
  document.title = `${td.title} · RobWoT`;
  const title = document.getElementById("title");
  if (title) title.textContent = td.title;

  const stage = new Stage(view);
  stage.start();
  const state: PageState = { robot: null, latest: null, tcpNow: null, calibration: null };
  const controls = addControls(td, stage, content, state);
  addProgramPanel(td, stage, content, state);
  const objectsPlot = new ObjectsPlot();
  const divergencePlot = new DivergencePlot([...new Set(td.joints.map((j) => j.unit))].join(", ") || "rad");
  content.append(objectsPlot.element, divergencePlot.element);
  drawLatestJoints(td, stage, state, controls.joints);

  // Everything loads in parallel; each failure is shown, the rest of the page keeps working.
  const loading = startLoading(td, stage, state, controls);
  const liveUrl = td.live ?? `${location.protocol === "https:" ? "wss:" : "ws:"}//${location.host}/live`;
  const othersTask = showOtherRobots(slug, stage, controls.motion, liveUrl);
  startLive(liveUrl, slug, {
    joints: (q, msg) => {
      state.latest = q;
      const p = msg["position"];
      if (isRecord(p) && typeof p["x"] === "number") {
        state.tcpNow = p as Point;
        controls.cartesian.showCurrent(state.tcpNow);
      }
    },
    status: (msg) => {
      controls.motion.showStatus(msg);
      debugState.lastStatus = msg;
      publishDebug();
      if (msg["state"] !== "moving") readProperty(td, "calibration").then(controls.showCalibration, (e: unknown) => showError("calibration", e));
    },
    scene: (msg) => {
      loading.obstacles.show(msg, true).catch((e: unknown) => showError("scene (live)", e));
      debugState.objectHistory = objectsPlot.record(msg["objects"]);
      publishDebug();
    },
    physical: (msg) => {
      loading.physical.show(msg);
      debugState.divergenceHistory = divergencePlot.record(msg);
      publishDebug();
    },
    divergence: (msg) => {
      debugState.divergenceHistory = divergencePlot.event(msg);
      publishDebug();
    },
    collision: (msg) => {
      debugState.collisions++;
      publishDebug();
      highlightCollision(stage, state.robot, msg);
    },
  });
  const { robotTask, sceneTask, cloudTask, surfaceTask, stateTask, reachTask } = loading;
  const results = await Promise.allSettled([robotTask, sceneTask, cloudTask, surfaceTask, stateTask, othersTask, reachTask]);
  const labels = ["model", "scene", TWIN_FILES.pointCloud, TWIN_FILES.surface, "state", "other robots of this world", TWIN_FILES.reachability];
  results.forEach((r, i) => {
    if (r.status === "rejected") showError(labels[i] ?? "load", r.reason);
  });
  const framed: Object3D[] = [];
  if (results[0].status === "fulfilled") framed.push(results[0].value);
  if (results[3].status === "fulfilled" && results[3].value) framed.push(results[3].value);
  else if (results[2].status === "fulfilled" && results[2].value) framed.push(results[2].value);
  if (results[5].status === "fulfilled" && results[5].value) framed.push(results[5].value);
  stage.frame(framed);
  debugState.phase = results[0].status === "fulfilled" ? "ready" : "error";
  publishDebug();
}

/** The motion, joint and Cartesian panels, wired to the TD's actions through one commander. */
function addControls(td: TwinTd, stage: Stage, content: HTMLElement, state: PageState): Controls {
  const motion = new MotionPanel(content, td.speed, () => void commander.stop());
  const commander = new Commander(td, {
    speed: () => motion.speed(),
    busy: (active) => (joints.targetActive = active),
    result: () => undefined, // the live status stream reports outcomes
    error: (action, err) => showError(action, err),
  });
  const joints = new JointPanel(content, td.joints, (target) => commander.moveJoints(target));
  const marker = new TargetMarker(stage);
  const cartesian = new CartesianPanel(content, commander, (t, valid, contacts = []) => {
    const position = state.calibration ? invertCalibration(state.calibration, t) : ([t.x, t.y, t.z] as [number, number, number]);
    marker.show(position, valid);
    debugState.target = { position, valid };
    publishDebug();
    // a rejected path: its touching bodies drawn red, as a collision event's are
    const sides = contacts.flatMap((c) => (isRecord(c) ? [c["a"], c["b"]] : []));
    if (sides.length > 0) highlightBodies(stage, state.robot, sides);
  });
  const showCalibration = (c: unknown): void => {
    try {
      state.calibration = activeCalibration(c);
    } catch (err) {
      state.calibration = null;
      showError("calibration", err);
    }
    motion.showCalibration(c);
    cartesian.setCalibrated(state.calibration !== null);
  };
  return { motion, joints, cartesian, showCalibration };
}

/** The program panel: its TCP path drawn by this page's model, its example starting at the reported TCP. */
function addProgramPanel(td: TwinTd, stage: Stage, content: HTMLElement, state: PageState): void {
  new ProgramPanel(
    content,
    td,
    stage,
    {
      tcpOf: (names, configurations) => {
        const robot = state.robot;
        const ee = robot && td.eeLink ? robot.links[td.eeLink] : undefined;
        if (!robot || !ee) return [];
        const saved = Object.fromEntries(Object.entries(robot.joints).map(([n, j]) => [n, Number(j.angle)]));
        const out = configurations.map((q) => {
          applyJoints(robot, Object.fromEntries(names.map((n, i) => [n, q[i] ?? 0])), td.couplings);
          const p = stage.positionInWorld(ee);
          return [p?.x ?? 0, p?.y ?? 0, p?.z ?? 0] as [number, number, number];
        });
        applyJoints(robot, saved);
        return out;
      },
      current: () => (state.tcpNow ? { joints: { ...debugState.joints }, tcp: state.tcpNow } : null),
      toView: (t) => (state.calibration ? invertCalibration(state.calibration, t) : [t.x, t.y, t.z]),
    },
    (drawn) => {
      debugState.program = drawn;
      publishDebug();
    },
  );
}

/** On each frame, the latest joints (if any arrived since) drawn on the model and the joint panel. */
function drawLatestJoints(td: TwinTd, stage: Stage, state: PageState, joints: JointPanel): void {
  const reportedUnknown = new Set<string>();
  stage.onFrame(() => {
    const { robot, latest } = state;
    if (!robot || !latest) return false;
    const unknown = applyJoints(robot, latest, td.couplings).filter((n) => !reportedUnknown.has(n));
    for (const n of unknown) {
      reportedUnknown.add(n);
      showError("live", `joint "${n}" is not in the model (known: ${Object.keys(robot.joints).join(", ")})`);
    }
    joints.showActual(latest);
    debugState.joints = { ...debugState.joints, ...latest };
    debugState.ee = td.eeLink ? stage.positionInWorld(robot.links[td.eeLink] ?? null) : null;
    debugState.framesApplied++;
    publishDebug();
    state.latest = null;
    return true;
  });
}

/** Starts loading the model (at its base pose), the scene, point cloud, surface, reachability and state. */
function startLoading(td: TwinTd, stage: Stage, state: PageState, controls: Controls) {
  const { motion, cartesian, showCalibration } = controls;
  const poseTask = loadBasePose(td).catch((err: unknown) => {
    showError(`${TWIN_FILES.manifest} (robot base pose; the robot is shown at the origin)`, err);
    return null;
  });
  const robotTask = loadRobot(td.links.model).then(async ({ robot: r, meshErrors }) => {
    for (const e of meshErrors) showError("model", e);
    const pose = await poseTask;
    if (pose) {
      r.position.set(...pose.position);
      r.quaternion.copy(xyzwToQuaternion(pose.orientation));
    }
    state.robot = r;
    stage.add(r);
    motion.addLayer("robot", true, (v) => stage.setVisible(r, v));
    return r;
  });
  const physical = new PhysicalRobotLayer(stage, motion, td.links.model, poseTask, () => state.robot, td.couplings);
  const obstacles = new ObstacleLayer(stage, motion, td.base);
  const sceneTask = loadScene(td, obstacles);
  const cloudTask = loadCloud(td, stage, motion);
  const surfaceTask = loadSurface(td, stage, motion);
  const reachTask = loadReachability(td, stage, motion);
  const stateTask = loadState(td, motion, cartesian, showCalibration).then((q) => (state.latest ??= q));
  return { robotTask, sceneTask, cloudTask, surfaceTask, reachTask, stateTask, physical, obstacles };
}

async function loadState(
  td: TwinTd,
  motion: MotionPanel,
  cartesian: CartesianPanel,
  showCalibration: (c: unknown) => void,
): Promise<Record<string, number>> {
  const [q, pose, status, calibration] = await Promise.all([
    readProperty(td, "getJointPosition"),
    readProperty(td, "getCartesianPosition"),
    readProperty(td, "motionStatus"),
    readProperty(td, "calibration"),
  ]);
  if (isRecord(status)) motion.showStatus(status);
  showCalibration(calibration);
  if (isRecord(pose) && typeof pose["x"] === "number") cartesian.showCurrent(pose as { x: number; y: number; z: number });
  if (!isRecord(q) || !Object.values(q).every((v) => typeof v === "number")) {
    throw new Error(`getJointPosition answered ${JSON.stringify(q)}`);
  }
  return q as Record<string, number>;
}

function startLive(
  url: string,
  slug: string,
  on: Pick<ConstructorParameters<typeof LiveClient>[2], "joints" | "status" | "collision" | "scene" | "physical" | "divergence">,
): void {
  const badge = document.getElementById("connection");
  // Count every message so tests and users can see the stream is flowing.
  const counted =
    <A extends unknown[]>(f: (...a: A) => void) =>
    (...a: A): void => {
      debugState.liveMessages++;
      f(...a);
    };
  new LiveClient(url, slug, {
    joints: counted(on.joints),
    status: counted(on.status),
    collision: counted(on.collision),
    scene: counted(on.scene),
    ...(on.physical ? { physical: counted(on.physical) } : {}),
    ...(on.divergence ? { divergence: counted(on.divergence) } : {}),
    connection: (open) => {
      debugState.liveConnected = open;
      publishDebug();
      if (badge) {
        badge.textContent = open ? "live" : "offline";
        badge.className = `badge ${open ? "on" : "off"}`;
      }
    },
    error: (err) => showError("live", err),
  }).connect();
}


/** Draws the named bodies red for HIGHLIGHT_MS (a link of this robot, else an obstacle by name); the
 * names go to the debug state. Returns them. */
function highlightBodies(stage: Stage, robot: URDFRobot | null, sides: readonly unknown[]): string[] {
  const names: string[] = [];
  for (const side of sides) {
    const link = isRecord(side) ? side["link"] : side;
    const body = isRecord(side) ? side["body"] : null;
    if (typeof link === "string" && robot?.links[link]) {
      highlightLink(robot.links[link], HIGHLIGHT_MS);
      names.push(link);
    } else if (typeof body === "string") {
      const obstacle = stage.worldRoot.getObjectByName(body);
      if (obstacle instanceof Mesh) flash(obstacle);
      names.push(body);
    }
  }
  debugState.highlighted = names;
  publishDebug();
  stage.invalidate();
  window.setTimeout(() => {
    debugState.highlighted = [];
    publishDebug();
    stage.invalidate();
  }, HIGHLIGHT_MS + 50);
  return names;
}

function highlightCollision(stage: Stage, robot: URDFRobot | null, msg: Record<string, unknown>): void {
  const pair = isRecord(msg["pair"]) ? msg["pair"] : {};
  const names = highlightBodies(stage, robot, [pair["a"], pair["b"]]);
  const p = msg["position"];
  if (isRecord(p) && typeof p["x"] === "number" && typeof p["y"] === "number" && typeof p["z"] === "number") {
    const marker = new Mesh(new SphereGeometry(0.02, 16, 8), new MeshBasicMaterial({ color: 0xff0000 }));
    marker.position.set(p["x"], p["y"], p["z"]);
    stage.add(marker);
    window.setTimeout(() => {
      marker.removeFromParent();
      stage.invalidate();
    }, HIGHLIGHT_MS);
  }
  showNotice("collision", `motion stopped by contact between ${names.join(" and ") || "unknown bodies"}`);
}

function flash(mesh: Mesh): void {
  const saved = mesh.material;
  mesh.material = new MeshBasicMaterial({ color: 0xe02020 });
  window.setTimeout(() => (mesh.material = saved), HIGHLIGHT_MS);
}
