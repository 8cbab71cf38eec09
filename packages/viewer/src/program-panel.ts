/**
 * Program panel: a program's steps as JSON (the TD's validateProgram / runProgram input), "Validate"
 * draws the TCP path of the timed trajectory the twin answers, one colour per step, and marks a refused
 * step red from where the program stands to its target; "Play" runs a marker along that path at the
 * trajectory's own time; "Run" asks the twin to run the program (the live stream then moves the model).
 * "Example" writes a program from the current pose: a LIN square of 10 cm and back home. Below the verdict,
 * `program-plots.ts` plots the validated trajectory: joint positions, joint velocities and the TCP speed.
 */
import { BufferGeometry, Group, Line, LineBasicMaterial, LineDashedMaterial, Mesh, MeshBasicMaterial, SphereGeometry, Vector3 } from "three";
import { el, fmt } from "./dom.js";
import { showError } from "./errors.js";
import { isRecord } from "./http.js";
import { ProgramPlots, type PlotsDrawn } from "./program-plots.js";
import type { Stage } from "./stage.js";
import { invokeAction, type TwinTd } from "./td.js";

type Xyz = [number, number, number];

interface StepVerdict {
  step: number;
  ok: boolean;
  reasons: string[];
  duration: number;
  planned?: string;
}

interface Report {
  valid: boolean;
  firstFailingStep?: number;
  cycleTime: number;
  steps: StepVerdict[];
  trajectory: { rate: number; names: string[]; positions: number[][] };
}

/** What the page gives the panel: the TCP position (view frame) of joint configurations, the current
 *  joints and TCP pose, and a Cartesian input's position in the view frame (calibration undone). */
export interface ProgramView {
  tcpOf(names: string[], configurations: number[][]): Xyz[];
  current(): { joints: Record<string, number>; tcp: { x: number; y: number; z: number } } | null;
  toView(p: { x: number; y: number; z: number }): Xyz;
}

/** What the page shows of the drawn program (tests read it through `window.__robwot.program`). */
export interface ProgramDrawn {
  valid: boolean;
  cycleTime: number;
  /** TCP points drawn per passed step */
  points: number[];
  /** the refused step drawn red, if any */
  failing: number | null;
  played: number;
  /** what the plots show (joint positions and velocities, TCP speed over time); null before a validation */
  plots: PlotsDrawn | null;
}

const COLOURS = [0x1f77b4, 0x2ca02c, 0x9467bd, 0x8c564b, 0x17becf, 0xbcbd22];

export class ProgramPanel {
  private readonly text = el("textarea", { name: "program", rows: "6", "aria-label": "program steps (JSON)", spellcheck: "false" });
  private readonly verdict = el("div", { class: "verdict", hidden: "" });
  private readonly layer = new Group();
  private readonly marker = new Mesh(new SphereGeometry(0.015, 12, 6), new MeshBasicMaterial({ color: 0xff8800 }));
  private path: { points: Xyz[]; rate: number } | null = null;
  private playing: { t0: number } | null = null;
  private readonly plots: ProgramPlots;

  constructor(
    parent: HTMLElement,
    private readonly td: TwinTd,
    stage: Stage,
    private readonly view: ProgramView,
    private readonly onDrawn: (drawn: ProgramDrawn) => void,
  ) {
    const button = (text: string, run: () => Promise<void> | void): HTMLButtonElement => {
      const b = el("button", { type: "button", text });
      b.addEventListener("click", () => void Promise.resolve(run()).catch((err: unknown) => showError(`program: ${text}`, err)));
      return b;
    };
    const units = new Map(td.joints.map((j) => [j.name, j.unit]));
    this.plots = new ProgramPlots((joint) => units.get(joint) ?? "");
    this.marker.visible = false;
    this.layer.add(this.marker);
    stage.add(this.layer);
    stage.onFrame(() => this.frame());
    parent.append(
      el(
        "section",
        { id: "program" },
        el("h2", { text: "Program" }),
        this.text,
        el("div", { class: "row" }, button("Example", () => this.example()), button("Validate", () => this.validate()), button("Play", () => this.play()), button("Run", () => this.run())),
        this.verdict,
        this.plots.element,
      ),
    );
  }

  private steps(): unknown {
    try {
      const parsed: unknown = JSON.parse(this.text.value);
      return Array.isArray(parsed) ? parsed : isRecord(parsed) && Array.isArray(parsed["steps"]) ? parsed["steps"] : null;
    } catch {
      return null;
    }
  }

  /** A LIN square of 10 cm in the horizontal plane from the current TCP position, then PTP home. */
  private example(): void {
    const now = this.view.current();
    if (!now) throw new Error("the twin's state is not known yet");
    const { x, y, z } = now.tcp;
    const at = (dx: number, dy: number): Record<string, unknown> => ({ motion: "lin", x: +(x + dx).toFixed(4), y: +(y + dy).toFixed(4), z: +z.toFixed(4), tcpSpeed: 0.1 });
    const steps = [at(0, 0.1), at(-0.1, 0.1), at(-0.1, 0), at(0, 0), { joints: now.joints }];
    this.text.value = JSON.stringify(steps, null, 1);
  }

  private async validate(): Promise<void> {
    const steps = this.steps();
    if (!steps) throw new Error("the program is not a JSON array of steps (or {\"steps\": [...]})");
    const report = (await invokeAction(this.td, "validateProgram", { steps })) as Report;
    this.show(report, steps as Record<string, unknown>[]);
  }

  private async run(): Promise<void> {
    const steps = this.steps();
    if (!steps) throw new Error("the program is not a JSON array of steps (or {\"steps\": [...]})");
    this.say(true, "running…");
    const r = await invokeAction(this.td, "runProgram", { steps });
    const out = isRecord(r) ? r : {};
    this.say(out["status"] === "reached", `run: ${String(out["status"])} in step ${String(out["step"])} after ${fmt(Number(out["duration"]))} s (cycle time ${fmt(Number(out["cycleTime"]))} s)`);
  }

  private play(): void {
    if (!this.path || this.path.points.length === 0) throw new Error("validate a program first");
    this.playing = { t0: performance.now() };
    this.marker.visible = true;
  }

  private frame(): boolean {
    if (!this.playing || !this.path) return false;
    const i = Math.floor(((performance.now() - this.playing.t0) / 1000) * this.path.rate);
    const p = this.path.points[Math.min(i, this.path.points.length - 1)];
    if (p) this.marker.position.set(...p);
    if (i >= this.path.points.length - 1) {
      this.playing = null;
      this.drawn = { ...this.drawn, played: this.drawn.played + 1 };
      this.onDrawn(this.drawn);
    }
    return true;
  }

  private drawn: ProgramDrawn = { valid: false, cycleTime: 0, points: [], failing: null, played: 0, plots: null };

  private say(ok: boolean, text: string): void {
    this.verdict.hidden = false;
    this.verdict.className = `verdict ${ok ? "ok" : "bad"}`;
    this.verdict.textContent = text;
  }

  /** The verdicts in words, and the path drawn: each passed step's TCP samples, a refused step red. */
  private show(report: Report, steps: Record<string, unknown>[]): void {
    const lines = report.steps.map((s) =>
      s.ok ? `step ${s.step}: ok (${s.planned ?? "ptp"}), ${fmt(s.duration)} s` : `step ${s.step}: refused: ${s.reasons.join("; ")}`,
    );
    this.say(report.valid, [`${report.valid ? "✔ valid" : `✘ refused at step ${String(report.firstFailingStep)}`}, cycle time ${fmt(report.cycleTime)} s`, ...lines].join("\n"));
    for (const child of [...this.layer.children]) if (child !== this.marker) child.removeFromParent();
    const { names, positions, rate } = report.trajectory;
    const tcp = this.view.tcpOf(names, positions);
    const points: number[] = [];
    const marks: number[] = [];
    let at = 0;
    let end = 0;
    for (const s of report.steps.filter((v) => v.ok)) {
      const n = Math.round(s.duration * rate);
      const part = tcp.slice(at, Math.min(tcp.length, at + n + 1));
      this.layer.add(line(part, new LineBasicMaterial({ color: COLOURS[s.step % COLOURS.length] })));
      points.push(part.length);
      at += n;
      end += s.duration;
      marks.push(end);
    }
    let failing: number | null = null;
    if (report.firstFailingStep !== undefined) {
      const k = report.firstFailingStep;
      const target = this.targetOf(steps[k], names);
      const from = tcp.at(-1);
      if (target && from) {
        const dashed = line([from, target], new LineDashedMaterial({ color: 0xe02020, dashSize: 0.02, gapSize: 0.01 }));
        dashed.computeLineDistances();
        this.layer.add(dashed);
        failing = k;
      }
    }
    this.path = { points: tcp, rate };
    const plots = positions.length > 0 ? this.plots.show(report.trajectory, tcp, marks.slice(0, -1), end) : null;
    if (!plots) this.plots.hide();
    this.drawn = { valid: report.valid, cycleTime: report.cycleTime, points, failing, played: this.drawn.played, plots };
    this.onDrawn(this.drawn);
  }

  /** Where a step goes, in the view frame: a pose's position, or the TCP of a joint target. */
  private targetOf(step: Record<string, unknown> | undefined, names: string[]): Xyz | null {
    if (!step) return null;
    if (typeof step["x"] === "number" && typeof step["y"] === "number" && typeof step["z"] === "number") {
      return this.view.toView({ x: step["x"], y: step["y"], z: step["z"] });
    }
    const joints = step["joints"];
    if (!isRecord(joints)) return null;
    return this.view.tcpOf(names, [names.map((n) => Number(joints[n] ?? 0))])[0] ?? null;
  }
}

function line(points: Xyz[], material: LineBasicMaterial | LineDashedMaterial): Line {
  return new Line(new BufferGeometry().setFromPoints(points.map((p) => new Vector3(...p))), material);
}
