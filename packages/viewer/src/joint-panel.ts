/**
 * Joint sliders within the TD's limits. A slider follows the live state unless the user holds it or a
 * target the user set is still being moved to; releasing it (`change`) commits all slider values.
 */
import { el, fmt } from "./dom.js";
import type { JointLimit } from "@robwot/core/browser";

export class JointPanel {
  private readonly sliders = new Map<string, { input: HTMLInputElement; out: HTMLOutputElement }>();
  private held: string | null = null;
  /** True while a move commanded from the sliders runs: sliders show the target, labels the actual value. */
  targetActive = false;

  constructor(
    parent: HTMLElement,
    limits: JointLimit[],
    private readonly commit: (joints: Record<string, number>) => void,
  ) {
    const box = el("section", { id: "joints" }, el("h2", { text: "Joints" }));
    for (const j of limits) {
      const input = el("input", {
        type: "range",
        name: j.name,
        min: String(j.lower),
        max: String(j.upper),
        step: "any",
        value: String(Math.min(Math.max(0, j.lower), j.upper)),
        "aria-label": `${j.name} (${j.unit})`,
        "data-joint": j.name,
      });
      const out = el("output", { text: "–" });
      input.addEventListener("pointerdown", () => (this.held = j.name));
      input.addEventListener("pointerup", () => (this.held = null));
      input.addEventListener("input", () => (out.textContent = `${fmt(Number(input.value))} → `));
      input.addEventListener("change", () => {
        this.held = null;
        this.commit(this.values());
      });
      const label = el("label", { title: `[${fmt(j.lower)}, ${fmt(j.upper)}] ${j.unit}`, text: j.name });
      box.append(el("div", { class: "joint" }, label, out, input));
      this.sliders.set(j.name, { input, out });
    }
    parent.append(box);
  }

  values(): Record<string, number> {
    const v: Record<string, number> = {};
    for (const [name, s] of this.sliders) v[name] = Number(s.input.value);
    return v;
  }

  /** Show the actual joint state (from the servient). */
  showActual(joints: Record<string, number>): void {
    for (const [name, value] of Object.entries(joints)) {
      const s = this.sliders.get(name);
      if (!s) continue;
      s.out.textContent = fmt(value);
      if (this.held !== name && !this.targetActive) s.input.value = String(value);
    }
  }
}
