/**
 * The physical robot a twin follows (`serve --follow`, or `--relay` with one twin): its joints arrive as
 * `/live` messages `type: "physical"` (the twin's `physicalState`). On the first one the page draws a second
 * copy of the robot at the twin's base pose with those joints: the real robot, solid; the simulated robot
 * (the plan) turns into a translucent ghost. Each has a layer switch. A twin that follows nothing draws
 * neither, and its robot stays solid.
 */
import { Material, Mesh, type Object3D } from "three";
import type { URDFRobot } from "urdf-loader";
import type { TdCoupling } from "@robwot/core/browser";
import { debugState, publishDebug } from "./debug.js";
import { showError } from "./errors.js";
import { isRecord } from "./http.js";
import type { MotionPanel } from "./motion-panel.js";
import { applyJoints, loadRobot } from "./robot.js";
import type { Stage } from "./stage.js";
import { xyzwToQuaternion } from "./three-frames.js";
import type { loadBasePose } from "./twin-data.js";

/** opacity of the simulated robot once the real one is drawn */
const GHOST_OPACITY = 0.3;

/** Makes every visual of `root` translucent (its own copies of the materials: urdf-loader shares them). */
function ghost(root: Object3D): void {
  root.traverse((o) => {
    if (!(o instanceof Mesh)) return;
    const one = (m: Material): Material => {
      const c = m.clone();
      c.transparent = true;
      c.opacity = GHOST_OPACITY;
      c.depthWrite = false;
      return c;
    };
    o.material = Array.isArray(o.material) ? o.material.map(one) : one(o.material as Material);
  });
}

export class PhysicalRobotLayer {
  private robot: URDFRobot | null = null;
  private loading = false;
  private latest: Record<string, number> | null = null;

  constructor(
    private readonly stage: Stage,
    private readonly motion: MotionPanel,
    private readonly modelUrl: string,
    private readonly basePose: Promise<Awaited<ReturnType<typeof loadBasePose>> | null>,
    /** the simulated robot, once loaded */
    private readonly simulated: () => URDFRobot | null,
    /** the twin's joints that follow others */
    private readonly couplings: readonly TdCoupling[] = [],
  ) {
    stage.onFrame(() => {
      if (!this.robot || !this.latest) return false;
      applyJoints(this.robot, this.latest, this.couplings);
      this.latest = null;
      return true;
    });
  }

  /** A `physical` message of `/live`: `{following, joints?, age?, divergence?, lastError?, ...}`. */
  show(msg: Record<string, unknown>): void {
    const joints = msg["joints"];
    const numeric = isRecord(joints) && Object.values(joints).every((v) => typeof v === "number");
    debugState.physical = {
      joints: numeric ? { ...(joints as Record<string, number>) } : {},
      age: typeof msg["age"] === "number" ? msg["age"] : null,
      drawn: this.robot !== null,
      ghost: debugState.physical?.ghost ?? false,
    };
    publishDebug();
    if (!numeric) return;
    this.latest = joints as Record<string, number>;
    if (!this.robot && !this.loading) void this.load();
  }

  private async load(): Promise<void> {
    this.loading = true;
    try {
      const [{ robot, meshErrors }, pose] = await Promise.all([loadRobot(this.modelUrl), this.basePose]);
      for (const e of meshErrors) showError("physical robot", e);
      if (pose) {
        robot.position.set(...pose.position);
        robot.quaternion.copy(xyzwToQuaternion(pose.orientation));
      }
      robot.name = "physical robot";
      this.robot = robot;
      this.stage.add(robot);
      this.motion.addLayer("physical robot", true, (v) => this.stage.setVisible(robot, v));
      const simulated = this.simulated();
      if (simulated) ghost(simulated);
      debugState.physical = { ...(debugState.physical ?? { joints: {}, age: null }), drawn: true, ghost: simulated !== null };
      publishDebug();
      this.stage.invalidate();
    } catch (err) {
      showError("physical robot", err);
    } finally {
      this.loading = false;
    }
  }
}
