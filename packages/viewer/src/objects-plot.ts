/**
 * The cell's objects over time: each object's x, y and z (m, world frame) from every /live `scene` message
 * (a belt carrying it, an arm lifting and placing it, a move of it), against the time since the page saw
 * the first one (s), one chart per axis, one line per object in a shared legend. The last `MAX_SAMPLES`
 * messages are kept; an object not in a message (removed, or not yet added) has a gap there.
 */
import { el } from "./dom.js";
import { drawChart, PLOT_COLOURS, type Chart } from "./program-plots.js";

/** scene messages kept */
export const MAX_SAMPLES = 2000;
const AXES = ["x", "y", "z"] as const;

/** What the plots hold (tests read it through `window.__robwot.objectHistory`). */
export interface ObjectHistory {
  samples: number;
  /** s from the first sample to the last */
  timeSpan: number;
  /** each object's positions (m), one per sample, null where it was not in the world */
  objects: Record<string, ([number, number, number] | null)[]>;
}

export class ObjectsPlot {
  readonly element: HTMLElement;
  private readonly legend = el("div", { class: "plot-legend" });
  private readonly canvases = AXES.map(() => el("canvas", { class: "plot", height: "140" }));
  private t0: number | null = null;
  private times: number[] = [];
  private tracks = new Map<string, ([number, number, number] | null)[]>();

  constructor(private readonly now: () => number = () => performance.now() / 1000) {
    this.element = el("section", { id: "objects-plot", hidden: "" }, el("h2", { text: "Objects over time" }), this.legend, ...this.canvases);
  }

  /** One /live `scene` message's objects: recorded, the plots drawn again; what they hold. */
  record(objects: unknown): ObjectHistory {
    const now = this.now();
    this.t0 ??= now;
    const seen = new Map<string, [number, number, number]>();
    for (const o of Array.isArray(objects) ? objects : []) {
      const { name, position } = (o ?? {}) as { name?: unknown; position?: unknown };
      if (typeof name === "string" && Array.isArray(position) && position.length === 3 && position.every((v) => typeof v === "number")) {
        seen.set(name, position as [number, number, number]);
      }
    }
    for (const name of seen.keys()) if (!this.tracks.has(name)) this.tracks.set(name, this.times.map(() => null));
    this.times.push(now - this.t0);
    for (const [name, track] of this.tracks) track.push(seen.get(name) ?? null);
    if (this.times.length > MAX_SAMPLES) {
      this.times = this.times.slice(-MAX_SAMPLES);
      for (const [name, track] of this.tracks) this.tracks.set(name, track.slice(-MAX_SAMPLES));
    }
    if (this.tracks.size > 0) this.draw();
    return this.history();
  }

  history(): ObjectHistory {
    return { samples: this.times.length, timeSpan: (this.times.at(-1) ?? 0) - (this.times[0] ?? 0), objects: Object.fromEntries(this.tracks) };
  }

  private draw(): void {
    const names = [...this.tracks.keys()];
    const colour = (k: number): string => PLOT_COLOURS[k % PLOT_COLOURS.length] ?? "#000";
    const start = this.times[0] ?? 0;
    const times = this.times.map((t) => t - start);
    AXES.forEach((axis, a) => {
      const series = names.map((name, k) => ({ name, colour: colour(k), values: (this.tracks.get(name) ?? []).map((p) => (p ? p[a]! : Number.NaN)) }));
      const chart: Chart = { times, title: `objects: ${axis}`, unit: "m", series, marks: [] };
      drawChart(this.canvases[a]!, chart, "no objects");
    });
    this.legend.replaceChildren(...names.map((n, k) => el("span", {}, el("i", { style: `background:${colour(k)}` }), n)));
    this.element.hidden = false;
  }
}
