/** Speed, Stop, motion status, calibration status and layer toggles. */
import { el, fmt } from "./dom.js";
import { isRecord } from "./http.js";

export class MotionPanel {
  readonly speedInput = el("input", { type: "range", name: "speed", "aria-label": "speed" });
  readonly stopButton = el("button", { type: "button", class: "stop", text: "STOP" });
  private readonly status = el("div", { class: "kv", id: "status", text: "state: –" });
  private readonly calibration = el("div", { class: "kv", id: "calibration", text: "calibration: –" });
  private readonly layers = el("div", { id: "layers" });

  /** `speed`: the range the twin's move actions accept (the TD's `speed` input schema). */
  constructor(parent: HTMLElement, speed: { minimum: number; maximum: number }, onStop: () => void) {
    // the slider steps by the smallest accepted fraction, so both ends of the range can be chosen
    Object.assign(this.speedInput, { min: String(speed.minimum), max: String(speed.maximum), step: String(speed.minimum), value: "0.5" });
    const speedOut = el("output", { text: "50 %" });
    this.speedInput.addEventListener("input", () => (speedOut.textContent = `${Math.round(this.speed() * 100)} %`));
    this.stopButton.addEventListener("click", onStop);
    parent.append(
      el(
        "section",
        { id: "motion" },
        el("h2", { text: "Motion" }),
        el("div", { class: "row" }, el("label", { text: "speed" }), this.speedInput, speedOut, this.stopButton),
        this.status,
        el("h2", { text: "Calibration" }),
        this.calibration,
        el("h2", { text: "Layers" }),
        this.layers,
        el(
          "div",
          { class: "legend" },
          el("span", { style: "background:#2973d9" }),
          "collision-free",
          el("span", { style: "background:#db3329" }),
          "colliding",
        ),
      ),
    );
  }

  speed(): number {
    return Number(this.speedInput.value);
  }

  showStatus(s: Record<string, unknown>): void {
    const lines = [`state: ${String(s["state"] ?? "–")}`];
    const err = s["lastError"];
    if (isRecord(err)) lines.push(`last error: ${String(err["code"])}: ${String(err["message"])}`);
    const res = s["lastResult"];
    if (isRecord(res)) {
      lines.push(`last result: ${String(res["status"])}${typeof res["duration"] === "number" ? ` in ${fmt(res["duration"], 2)} s` : ""}`);
    }
    this.status.textContent = lines.join("\n");
  }

  showCalibration(c: unknown): void {
    if (!isRecord(c) || c["active"] !== true) {
      this.calibration.textContent = "not calibrated (virtual frame = real frame)";
      return;
    }
    const t = Array.isArray(c["translation"]) ? c["translation"].map((v) => fmt(Number(v))).join(", ") : "?";
    this.calibration.textContent = [
      "active",
      `scale ${typeof c["scale"] === "number" ? fmt(c["scale"], 5) : "?"}`,
      `translation [${t}] m`,
      `rms ${typeof c["rms"] === "number" ? `${fmt(c["rms"] * 1000, 2)} mm` : "?"} over ${String(c["pairs"] ?? "?")} pairs`,
      typeof c["createdAt"] === "string" ? `created ${c["createdAt"]}` : "",
    ]
      .filter(Boolean)
      .join("\n");
  }

  /** A checkbox that toggles a layer's visibility. */
  addLayer(label: string, initial: boolean, set: (visible: boolean) => void): void {
    const box = el("input", { type: "checkbox", name: `layer-${label}` });
    box.checked = initial;
    box.addEventListener("change", () => set(box.checked));
    this.layers.append(el("label", { class: "row" }, box, label));
  }
}
