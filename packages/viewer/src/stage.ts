/**
 * Renderer, camera, lights, orbit controls and the render loop. Renders on demand (when something
 * changed) at display rate via requestAnimationFrame; per-frame hooks run first (e.g. apply the latest
 * live joint state).
 */
import {
  AmbientLight,
  Box3,
  Color,
  DirectionalLight,
  GridHelper,
  HemisphereLight,
  Mesh,
  MeshPhongMaterial,
  type Object3D,
  PerspectiveCamera,
  Scene,
  SphereGeometry,
  Vector3,
  WebGLRenderer,
} from "three";
import { OrbitControls } from "three/examples/jsm/controls/OrbitControls.js";
import { createWorldRoot, urdfToThree } from "./three-frames.js";

export class Stage {
  readonly scene = new Scene();
  /** Parent of everything built from twin data, in URDF world coordinates (see three-frames.ts). */
  readonly worldRoot = createWorldRoot();
  readonly camera = new PerspectiveCamera(45, 1, 0.01, 100);
  readonly renderer: WebGLRenderer;
  readonly controls: OrbitControls;
  private dirty = true;
  private readonly hooks: Array<() => boolean> = [];

  constructor(private readonly container: HTMLElement) {
    this.renderer = new WebGLRenderer({ antialias: false });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio, 2));
    container.append(this.renderer.domElement);
    this.scene.background = new Color(0xf4f6f9);
    this.scene.add(new HemisphereLight(0xffffff, 0x667788, 1.1));
    this.scene.add(new AmbientLight(0xffffff, 0.15));
    const sun = new DirectionalLight(0xffffff, 1.8);
    sun.position.copy(urdfToThree([2, 1.5, 4]));
    this.scene.add(sun);
    // The floor grid lives in three.js's own frame: its XZ plane is the URDF's XY plane (z = 0).
    const grid = new GridHelper(4, 40, 0x9aa5b1, 0xd0d6de);
    this.scene.add(grid, this.worldRoot);
    this.camera.position.copy(urdfToThree([2, 1.2, 1.4]));
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.enableDamping = false;
    this.controls.addEventListener("change", () => this.invalidate());
    new ResizeObserver(() => this.resize()).observe(container);
    this.resize();
  }

  /** Register a per-frame hook; it returns true when it changed the scene. */
  onFrame(hook: () => boolean): void {
    this.hooks.push(hook);
  }

  invalidate(): void {
    this.dirty = true;
  }

  /** Origin of `obj`'s frame in URDF world coordinates (through worldRoot, see three-frames.ts). */
  positionInWorld(obj: Object3D | null): { x: number; y: number; z: number } | null {
    if (!obj) return null;
    this.scene.updateMatrixWorld(true);
    const p = this.worldRoot.worldToLocal(obj.getWorldPosition(new Vector3()));
    return { x: p.x, y: p.y, z: p.z };
  }

  setVisible(obj: Object3D, visible: boolean): void {
    obj.visible = visible;
    this.invalidate();
  }

  add(obj: Object3D): void {
    this.worldRoot.add(obj);
    this.invalidate();
  }

  start(): void {
    // Rendering may be slow (software WebGL: 100+ ms a frame). Keep the page responsive: after a frame
    // that took `cost` ms, wait at least as long before the next one (at most ~50% of the main thread).
    let cost = 0;
    let lastEnd = 0;
    const tick = (now: number): void => {
      for (const hook of this.hooks) if (hook()) this.dirty = true;
      if (this.dirty && now - lastEnd >= cost) {
        this.dirty = false;
        const t0 = performance.now();
        this.renderer.render(this.scene, this.camera);
        lastEnd = performance.now();
        cost = lastEnd - t0;
      }
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }

  /** Aim the camera at `objects` (three.js world bounding box) from the front-right, above. */
  frame(objects: Object3D[]): void {
    this.scene.updateMatrixWorld(true);
    const box = new Box3();
    for (const o of objects) box.expandByObject(o);
    if (box.isEmpty()) return;
    const centre = box.getCenter(new Vector3());
    const radius = box.getSize(new Vector3()).length() / 2;
    const fov = (this.camera.fov * Math.PI) / 180;
    const distance = (radius / Math.sin(fov / 2)) * 0.8;
    const dir = urdfToThree([1.3, 0.9, 0.75]).normalize();
    this.camera.position.copy(centre).addScaledVector(dir, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 20;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.invalidate();
  }

  private resize(): void {
    const w = Math.max(1, this.container.clientWidth);
    const h = Math.max(1, this.container.clientHeight);
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.invalidate();
  }
}

/** A small sphere marking the Cartesian target: grey until validated, then green (valid) or red. */
export class TargetMarker {
  private readonly mesh = new Mesh(new SphereGeometry(0.025, 24, 12), new MeshPhongMaterial({ color: 0x888888 }));

  constructor(private readonly stage: Stage) {
    this.mesh.name = "cartesian target";
    this.mesh.visible = false;
    stage.add(this.mesh);
  }

  show(p: readonly [number, number, number], valid: boolean | null): void {
    this.mesh.position.set(p[0], p[1], p[2]);
    (this.mesh.material as MeshPhongMaterial).color.setHex(valid === null ? 0x888888 : valid ? 0x2a9d4b : 0xd03030);
    this.mesh.visible = true;
    this.stage.invalidate();
  }
}
