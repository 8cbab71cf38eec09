/**
 * The physical robot's divergence over time, shown only while the twin follows one (`serve --follow`, or
 * `--relay` with one twin; `robwot emulate` stands in for it): canvas 2D like the other plots, time (s) along
 * x from the first reading with a divergence, a gap where a relayed command ended.
 *
 * What reaches the page, and so what is plotted: every `/live` `physical` message (the twin's
 * `physicalState`) carries, while a move is relayed, `divergence: {joint, tcp}`, the servient's own
 * comparison of that reading with the simulated motion at the same time since the command was sent
 * (`packages/servient/src/divergence.ts`): the largest joint difference (rad, m for a prismatic joint) and the
 * end effector's distance (m); and `maxDivergence: {joint, tcp, bound}`, the largest of the last relayed
 * command with the `--divergence-bound`, drawn as a dashed line. The `divergence` event (once per relayed
 * command, when a reading's joint divergence passes the bound) is its own `/live` message: it is marked at
 * that reading (a dashed vertical line), with the per-joint differences it carries (physical minus
 * expected). The values are the servient's, nothing is recomputed, keyed by the reading's `timestamp` (a
 * message repeated without a new reading is not a new sample). Per-joint differences over time are not
 * plotted: the servient sends only the largest, and the page cannot compute them from what it has, since
 * the simulated motion they are taken against is the relayed command's planned states shifted to when it was
 * sent to the robot, and the simulated robot has already ended that motion when the relay starts: its
 * `/live` joints at a reading's time are not the expected ones.
 */
import { el, fmt } from "./dom.js";
import { isRecord } from "./http.js";
import { drawChart, type Chart } from "./program-plots.js";

/** entries kept (readings with a divergence, and one gap after each relayed command) */
export const MAX_SAMPLES = 2000;
const COLOUR = { joint: "#1f77b4", tcp: "#ff7f0e", bound: "#d62728" } as const;

/** A `divergence` event: the reading that passed the bound. */
export interface DivergenceEvent {
  /** s on the plot's time axis: the reading it was raised for; null until that reading arrives */
  at: number | null;
  /** rad (largest joint difference), m (end effector), the bound (rad), s since the command was sent */
  joint: number;
  tcp: number;
  bound: number;
  time: number;
  /** physical minus expected, per joint (rad or m) */
  differences: Record<string, number>;
}

/** What the plot holds (tests read it through `window.__robwot.divergenceHistory`). */
export interface DivergenceHistory {
  /** entries: each a reading, null values a gap (the relayed command ended) */
  samples: number;
  /** s from the first entry to the last */
  timeSpan: number;
  /** s since the first reading with a divergence, per entry */
  times: number[];
  /** the reading's `timestamp` (ISO 8601) per entry */
  timestamps: string[];
  /** the largest joint difference (rad or m) and the end effector's distance (m) per entry */
  joint: (number | null)[];
  tcp: (number | null)[];
  /** the servient's `maxDivergence` of the last relayed command, and the event's bound (rad) */
  max: { joint: number; tcp: number } | null;
  bound: number | null;
  events: DivergenceEvent[];
}

const num = (v: unknown): number | null => (typeof v === "number" && Number.isFinite(v) ? v : null);

export class DivergencePlot {
  readonly element: HTMLElement;
  private readonly legend = el("div", { class: "plot-legend" });
  private readonly note = el("p", { class: "verdict" });
  private readonly canvases = [0, 1].map(() => el("canvas", { class: "plot", height: "140" }));
  private t0: number | null = null;
  private lastStamp: string | null = null;
  private h: DivergenceHistory = { samples: 0, timeSpan: 0, times: [], timestamps: [], joint: [], tcp: [], max: null, bound: null, events: [] };

  /** `unit`: the joints' units (rad, or "rad, m" with a prismatic joint) */
  constructor(private readonly unit = "rad") {
    this.element = el("section", { id: "divergence-plot", hidden: "" }, el("h2", { text: "Divergence from the physical robot" }), this.legend, ...this.canvases, this.note);
  }

  /** A `/live` `physical` message: shown while it says `following`, its reading recorded; what the plot holds. */
  record(msg: Record<string, unknown>): DivergenceHistory {
    const wasHidden = this.element.hidden;
    this.element.hidden = msg["following"] !== true;
    const max = msg["maxDivergence"];
    if (isRecord(max) && num(max["joint"]) !== null && num(max["tcp"]) !== null) {
      this.h.max = { joint: max["joint"] as number, tcp: max["tcp"] as number };
      this.h.bound = num(max["bound"]) ?? this.h.bound;
    }
    const stamp = typeof msg["timestamp"] === "string" ? msg["timestamp"] : null;
    const at = stamp === null ? Number.NaN : Date.parse(stamp) / 1000;
    const d = isRecord(msg["divergence"]) ? msg["divergence"] : {};
    const [joint, tcp] = [num(d["joint"]), num(d["tcp"])];
    const fresh = stamp !== null && Number.isFinite(at) && stamp !== this.lastStamp;
    if (fresh && joint !== null && tcp !== null) this.push(at, stamp, joint, tcp);
    else if (fresh && this.h.joint.length > 0 && this.h.joint.at(-1) !== null) this.push(at, stamp, null, null);
    else if (!wasHidden || this.element.hidden) return this.history();
    this.draw();
    return this.history();
  }

  /** A `/live` `divergence` event: marked at its reading (this one or the next with the same joint divergence). */
  event(msg: Record<string, unknown>): DivergenceHistory {
    const [joint, tcp, bound, time] = [num(msg["joint"]), num(msg["tcp"]), num(msg["bound"]), num(msg["time"])];
    if (joint === null || tcp === null || bound === null || time === null) return this.history();
    const [q, expected] = [msg["joints"], msg["expected"]];
    const differences: Record<string, number> = {};
    if (isRecord(q) && isRecord(expected)) {
      for (const [name, v] of Object.entries(q)) {
        const e = expected[name];
        if (typeof v === "number" && typeof e === "number") differences[name] = v - e;
      }
    }
    const last = this.h.joint.length - 1;
    const at = last >= 0 && this.h.joint[last] === joint ? (this.h.times[last] ?? null) : null;
    this.h.events.push({ at, joint, tcp, bound, time, differences });
    this.h.bound = bound;
    this.draw();
    return this.history();
  }

  history(): DivergenceHistory {
    const { times } = this.h;
    return { ...this.h, samples: times.length, timeSpan: (times.at(-1) ?? 0) - (times[0] ?? 0) };
  }

  private push(at: number, stamp: string, joint: number | null, tcp: number | null): void {
    this.lastStamp = stamp;
    this.t0 ??= at;
    const t = at - this.t0;
    const h = this.h;
    h.times.push(t);
    h.timestamps.push(stamp);
    h.joint.push(joint);
    h.tcp.push(tcp);
    // the event comes before the physical message of the reading that raised it
    for (const e of h.events) if (e.at === null && e.joint === joint) e.at = t;
    if (h.times.length > MAX_SAMPLES) {
      for (const key of ["times", "timestamps", "joint", "tcp"] as const) h[key] = h[key].slice(-MAX_SAMPLES) as never;
      h.events = h.events.filter((e) => e.at === null || e.at >= (h.times[0] ?? 0));
    }
  }

  private draw(): void {
    const { times, joint, tcp, bound, events, max } = this.h;
    const start = times[0] ?? 0;
    const shifted = times.map((t) => t - start);
    const marks = events.flatMap((e) => (e.at === null ? [] : [e.at - start]));
    const values = (v: (number | null)[]): number[] => v.map((x) => x ?? Number.NaN);
    const has = times.length > 0;
    const charts: Chart[] = [
      {
        times: shifted,
        title: "largest joint divergence",
        unit: this.unit,
        series: has ? [{ name: "joint", colour: COLOUR.joint, values: values(joint) }] : [],
        marks,
        levels: bound === null ? [] : [{ value: bound, colour: COLOUR.bound }],
      },
      { times: shifted, title: "TCP divergence", unit: "m", series: has ? [{ name: "TCP", colour: COLOUR.tcp, values: values(tcp) }] : [], marks },
    ];
    charts.forEach((c, k) => drawChart(this.canvases[k]!, c, "no move relayed yet"));
    const key = (colour: string, text: string): HTMLElement => el("span", {}, el("i", { style: `background:${colour}` }), text);
    this.legend.replaceChildren(key(COLOUR.joint, "largest joint"), key(COLOUR.tcp, "TCP"), ...(bound === null ? [] : [key(COLOUR.bound, `bound ${fmt(bound)} ${this.unit}`)]));
    const lines = max ? [`last relayed command: largest ${fmt(max.joint)} ${this.unit}, TCP ${fmt(max.tcp)} m`] : [];
    const last = events.at(-1);
    if (last) {
      const worst = Object.entries(last.differences).sort((a, b) => Math.abs(b[1]) - Math.abs(a[1]))[0];
      lines.push(`bound passed ${fmt(last.time, 2)} s after the command: ${fmt(last.joint)} ${this.unit}${worst ? ` (${worst[0]} ${fmt(worst[1])})` : ""}`);
    }
    this.note.textContent = lines.join("; ");
  }
}
