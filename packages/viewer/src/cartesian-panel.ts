/**
 * Cartesian target form: "Validate" asks the twin (validateCartesianPosition) and shows the verdict;
 * "Move" is enabled only for the validated, unchanged, valid target.
 */
import type { Commander } from "./commander.js";
import { el, fmt } from "./dom.js";
import { showError } from "./errors.js";
import { isRecord } from "./http.js";

type Target = { x: number; y: number; z: number };
/** How the end effector gets there: joint interpolation, or the straight line (the TD's `motion`). */
type Motion = "ptp" | "lin";

export class CartesianPanel {
  private readonly inputs: Record<keyof Target, HTMLInputElement>;
  private readonly verdict = el("div", { class: "verdict", hidden: "" });
  private readonly validateButton = el("button", { type: "button", text: "Validate" });
  private readonly moveButton = el("button", { type: "button", text: "Move", disabled: "" });
  private readonly motion = el("select", { name: "motion", "aria-label": "motion" }, el("option", { value: "ptp", text: "PTP (joint interpolation)" }), el("option", { value: "lin", text: "LIN (straight line)" }));
  private validated: string | null = null;
  private edited = false;

  private readonly heading = el("h2", { text: "Cartesian target (world frame)" });

  constructor(
    parent: HTMLElement,
    private readonly commander: Commander,
    /** The target and its verdict (null: not validated, e.g. edited since), to mark it in the view. */
    /** `contacts`: what the rejected plan's path touches (`checks.path.contacts`; empty when none) */
    private readonly onVerdict: (target: Target, valid: boolean | null, contacts?: readonly unknown[]) => void = () => undefined,
  ) {
    const input = (axis: keyof Target): HTMLInputElement => {
      const i = el("input", { type: "number", step: "0.01", name: axis, "aria-label": `${axis} (m)`, value: "0" });
      i.addEventListener("input", () => {
        this.edited = true;
        this.invalidate();
      });
      return i;
    };
    this.inputs = { x: input("x"), y: input("y"), z: input("z") };
    const row = el("div", { class: "row" });
    for (const axis of ["x", "y", "z"] as const) row.append(el("label", { text: axis }), this.inputs[axis]);
    row.append(el("span", { text: "m" }));
    this.motion.addEventListener("change", () => this.invalidate());
    this.validateButton.addEventListener("click", () => void this.validate());
    this.moveButton.addEventListener("click", () => void this.move());
    parent.append(
      el(
        "section",
        { id: "cartesian" },
        this.heading,
        row,
        el("div", { class: "row" }, this.motion, this.validateButton, this.moveButton),
        this.verdict,
      ),
    );
  }

  /** Cartesian inputs are in the real frame while a calibration is active. */
  setCalibrated(active: boolean): void {
    this.heading.textContent = active ? "Cartesian target (real frame, calibrated)" : "Cartesian target (world frame)";
  }

  /** Pre-fill with the current end-effector position until the user edits the form. */
  showCurrent(p: Target): void {
    if (this.edited) return;
    for (const axis of ["x", "y", "z"] as const) this.inputs[axis].value = fmt(p[axis]);
  }

  private target(): Target | null {
    const t = { x: Number(this.inputs.x.value), y: Number(this.inputs.y.value), z: Number(this.inputs.z.value) };
    return Object.values(t).every((v) => Number.isFinite(v)) && Object.values(this.inputs).every((i) => i.value !== "")
      ? t
      : null;
  }

  private chosenMotion(): Motion {
    return this.motion.value === "lin" ? "lin" : "ptp";
  }

  private invalidate(): void {
    this.validated = null;
    this.moveButton.disabled = true;
    this.verdict.hidden = true;
    const t = this.target();
    if (t) this.onVerdict(t, null);
  }

  private async validate(): Promise<void> {
    const t = this.target();
    if (!t) {
      this.show(false, "Enter numbers for x, y and z (metres).");
      return;
    }
    this.validateButton.disabled = true;
    try {
      const report = await this.commander.validateCartesian(t, this.chosenMotion());
      const valid = isRecord(report) && report["valid"] === true;
      this.show(valid, describeReport(report));
      this.validated = valid ? JSON.stringify(t) : null;
      this.moveButton.disabled = !valid;
      this.onVerdict(t, valid, pathContacts(report));
    } catch (err) {
      showError("validateCartesianPosition", err);
      this.invalidate();
    } finally {
      this.validateButton.disabled = false;
    }
  }

  private async move(): Promise<void> {
    const t = this.target();
    if (!t || this.validated !== JSON.stringify(t)) {
      this.invalidate();
      return;
    }
    this.moveButton.disabled = true;
    this.edited = false;
    await this.commander.moveCartesian(t, this.chosenMotion());
    this.invalidate();
  }

  private show(ok: boolean, text: string): void {
    this.verdict.hidden = false;
    this.verdict.className = `verdict ${ok ? "ok" : "bad"}`;
    this.verdict.textContent = text;
  }
}

/** The contacts of a plan's path check (the first colliding state's), or none. */
function pathContacts(report: unknown): unknown[] {
  const checks = isRecord(report) && isRecord(report["checks"]) ? report["checks"] : {};
  const path = isRecord(checks["path"]) ? checks["path"] : {};
  return Array.isArray(path["contacts"]) ? path["contacts"] : [];
}

/** "body/link" or "body" of one side of a contact. */
function side(s: unknown): string {
  if (!isRecord(s)) return "?";
  return typeof s["link"] === "string" ? `${String(s["body"])}/${s["link"]}` : String(s["body"]);
}

function describeReport(report: unknown): string {
  if (!isRecord(report)) return `unexpected answer: ${JSON.stringify(report)}`;
  const lines = [report["valid"] === true ? "✔ valid: the twin can move there" : "✘ rejected"];
  if (Array.isArray(report["reasons"])) for (const r of report["reasons"]) lines.push(`• ${String(r)}`);
  // the touching pairs, drawn red in the view as well
  for (const c of pathContacts(report).slice(0, 3)) if (isRecord(c)) lines.push(`  touching: ${side(c["a"])} ↔ ${side(c["b"])}`);
  const checks = isRecord(report["checks"]) ? report["checks"] : {};
  for (const [name, c] of Object.entries(checks)) {
    if (!isRecord(c)) continue;
    const extra = Object.entries(c)
      .filter(([k, v]) => k !== "ok" && typeof v === "number")
      // counts (IK solutions tried) as integers, lengths (m) with 4 decimals
      .map(([k, v]) => `${k}=${Number.isInteger(v) ? String(v) : fmt(v as number, 4)}`)
      .join(" ");
    const planned = typeof c["planned"] === "string" ? ` planned=${c["planned"]}` : "";
    lines.push(`${c["ok"] === true ? "ok " : c["ok"] === false ? "NO " : "–  "} ${name} ${extra}${planned}`);
  }
  return lines.join("\n");
}
