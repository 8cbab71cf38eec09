/**
 * Plots of a validated program, drawn with plain canvas 2D: the joint positions and the joint velocities
 * over time (one line per joint, a shared legend) and the TCP speed over time. Everything comes from the
 * trajectory validateProgram answers (joint states sampled at `rate` Hz, sample i at t = i / rate s, the
 * last one the state where the passed steps end, at the sum of their durations) and the TCP positions the
 * program panel computes per sample with the page's model; velocities and the TCP speed are central
 * differences of those samples (one-sided at both ends). Dashed lines mark where one step
 * ends and the next begins.
 */
import { el } from "./dom.js";

/** What the plots show (tests read it through `window.__robwot.program.plots`). */
export interface PlotsDrawn {
  /** samples per second of the trajectory (Hz) and how many samples are plotted */
  rate: number;
  samples: number;
  /** time of the last sample (s): where the passed steps end; the first is at 0 */
  timeSpan: number;
  /** the joints plotted, in the trajectory's order, with their units (rad or m) */
  joints: string[];
  units: string[];
  /** the plotted positions per joint (rad or m) */
  positions: Record<string, number[]>;
  /** the largest |velocity| per joint (rad/s or m/s) */
  maxVelocity: Record<string, number>;
  /** the largest TCP speed (m/s); null when the page has no TCP positions (no model loaded) */
  maxTcpSpeed: number | null;
}

export interface Series {
  name: string;
  colour: string;
  values: number[];
}

export interface Chart {
  /** the samples' times (s) */
  times: number[];
  title: string;
  unit: string;
  series: Series[];
  /** times (s) where one step ends and the next begins, drawn as dashed lines */
  marks: number[];
  /** values drawn as dashed horizontal lines in their colour (a bound), always within the y range */
  levels?: { value: number; colour: string }[];
}

export const PLOT_COLOURS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];

/** The samples' times (s): i / rate, the last one at `end` (where the trajectory ends). */
export function sampleTimes(n: number, rate: number, end: number): number[] {
  return Array.from({ length: n }, (_, i) => (i === n - 1 && n > 1 ? end : Math.min(i / rate, end)));
}

/** d/dt of samples taken at `times` (s): central differences, one-sided at the ends (0 over no time). */
export function derivative(values: number[], times: number[]): number[] {
  const n = values.length;
  return values.map((_, i) => {
    const [a, b] = [Math.max(0, i - 1), Math.min(n - 1, i + 1)];
    const dt = (times[b] ?? 0) - (times[a] ?? 0);
    return dt > 0 ? ((values[b] ?? 0) - (values[a] ?? 0)) / dt : 0;
  });
}

/** The speed (m/s) of points taken at `times` (s). */
export function speedOf(points: [number, number, number][], times: number[]): number[] {
  const axes = [0, 1, 2].map((k) => derivative(points.map((p) => p[k] ?? 0), times));
  return points.map((_, i) => Math.hypot(axes[0]?.[i] ?? 0, axes[1]?.[i] ?? 0, axes[2]?.[i] ?? 0));
}

const velocityUnit = (unit: string): string => `${unit}/s`;
const joined = (units: string[]): string => [...new Set(units)].join(", ");
const maxAbs = (values: number[]): number => values.reduce((m, v) => Math.max(m, Math.abs(v)), 0);

/** The plots' section of the program panel: three canvases and the joints' legend. */
export class ProgramPlots {
  readonly element = el("div", { class: "plots", hidden: "" });
  private readonly legend = el("div", { class: "plot-legend" });
  private readonly canvases = [0, 1, 2].map(() => el("canvas", { class: "plot", height: "140" }));

  constructor(private readonly unitOf: (joint: string) => string) {
    const [positions, velocities, tcp] = this.canvases;
    this.element.append(this.legend, positions!, velocities!, tcp!);
  }

  /** Plot a trajectory (`positions[i]` the joints `names` at i / rate s, the last at `end` s), its TCP
   *  points (may be empty) and the times (s) where its steps meet. */
  show(trajectory: { rate: number; names: string[]; positions: number[][] }, tcp: [number, number, number][], marks: number[], end: number): PlotsDrawn {
    const { rate, names, positions } = trajectory;
    const times = sampleTimes(positions.length, rate, end);
    const units = names.map((n) => this.unitOf(n));
    const byJoint = names.map((_, j) => positions.map((q) => q[j] ?? 0));
    const velocities = byJoint.map((v) => derivative(v, times));
    const colour = (j: number): string => PLOT_COLOURS[j % PLOT_COLOURS.length] ?? "#000";
    const series = (values: number[][]): Series[] => values.map((v, j) => ({ name: names[j] ?? "", colour: colour(j), values: v }));
    const speed = tcp.length === positions.length ? speedOf(tcp, times) : [];
    const charts: Chart[] = [
      { times, title: "joint positions", unit: joined(units), series: series(byJoint), marks },
      { times, title: "joint velocities", unit: joined(units.map(velocityUnit)), series: series(velocities), marks },
      { times, title: "TCP speed", unit: "m/s", series: speed.length > 0 ? [{ name: "TCP", colour: "#d62728", values: speed }] : [], marks },
    ];
    this.legend.replaceChildren(...names.map((n, j) => el("span", {}, el("i", { style: `background:${colour(j)}` }), n)));
    this.element.hidden = false;
    charts.forEach((c, k) => drawChart(this.canvases[k]!, c));
    return {
      rate,
      samples: positions.length,
      timeSpan: times.at(-1) ?? 0,
      joints: names,
      units,
      positions: Object.fromEntries(names.map((n, j) => [n, byJoint[j] ?? []])),
      maxVelocity: Object.fromEntries(names.map((n, j) => [n, maxAbs(velocities[j] ?? [])])),
      maxTcpSpeed: speed.length > 0 ? maxAbs(speed) : null,
    };
  }

  hide(): void {
    this.element.hidden = true;
  }
}

/** About five round steps (1, 2 or 5 times a power of ten) covering [lo, hi]. */
export function ticks(lo: number, hi: number): number[] {
  const span = hi - lo || 1;
  const raw = span / 5;
  const power = 10 ** Math.floor(Math.log10(raw));
  const step = ([1, 2, 5, 10].find((m) => m * power >= raw) ?? 10) * power;
  const out: number[] = [];
  for (let k = Math.ceil(lo / step - 1e-9); k * step <= hi + step * 1e-9; k++) out.push(k === 0 ? 0 : k * step);
  return out;
}

const PAD = { left: 44, right: 8, top: 18, bottom: 26 };

/** One chart: axes with ticks in SI units, time along x (s), each series a line; `empty` said when it has none. */
export function drawChart(canvas: HTMLCanvasElement, chart: Chart, empty = "no TCP positions (no model)"): void {
  const ratio = window.devicePixelRatio || 1;
  const width = canvas.clientWidth || 300;
  const height = 140;
  canvas.width = Math.round(width * ratio);
  canvas.height = Math.round(height * ratio);
  const ctx = canvas.getContext("2d");
  if (!ctx) return;
  ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
  ctx.clearRect(0, 0, width, height);
  const n = Math.max(0, ...chart.series.map((s) => s.values.length));
  const levels = chart.levels ?? [];
  const all = [...chart.series.flatMap((s) => s.values), ...levels.map((l) => l.value)].filter(Number.isFinite); // NaN: a gap in a series
  let lo = Math.min(0, ...all);
  let hi = Math.max(0, ...all);
  if (hi - lo < 1e-9) [lo, hi] = [lo - 1, hi + 1];
  const tEnd = (n > 1 ? chart.times[n - 1] : undefined) || 1;
  const box = { x: PAD.left, y: PAD.top, w: width - PAD.left - PAD.right, h: height - PAD.top - PAD.bottom };
  const x = (t: number): number => box.x + (t / tEnd) * box.w;
  const y = (v: number): number => box.y + box.h - ((v - lo) / (hi - lo)) * box.h;
  axes(ctx, chart, box, { x, y, lo, hi, tEnd });
  if (n === 0) {
    ctx.fillStyle = "#889";
    ctx.fillText(empty, box.x + 8, box.y + box.h / 2);
  }
  ctx.setLineDash([6, 4]);
  for (const l of levels) {
    ctx.strokeStyle = l.colour;
    ctx.beginPath();
    ctx.moveTo(box.x, y(l.value));
    ctx.lineTo(box.x + box.w, y(l.value));
    ctx.stroke();
  }
  ctx.setLineDash([]);
  ctx.lineWidth = 1.5;
  for (const s of chart.series) {
    ctx.strokeStyle = s.colour;
    ctx.beginPath();
    s.values.forEach((v, i) => {
      if (!Number.isFinite(v)) return;
      if (i === 0 || !Number.isFinite(s.values[i - 1] ?? Number.NaN)) ctx.moveTo(x(chart.times[i] ?? 0), y(v));
      else ctx.lineTo(x(chart.times[i] ?? 0), y(v));
    });
    ctx.stroke();
  }
}

interface Scale {
  x(t: number): number;
  y(v: number): number;
  lo: number;
  hi: number;
  tEnd: number;
}

/** The frame, grid, tick labels, the title with its unit and the time axis' label. */
function axes(ctx: CanvasRenderingContext2D, chart: Chart, box: { x: number; y: number; w: number; h: number }, s: Scale): void {
  ctx.font = "10px system-ui, sans-serif";
  ctx.strokeStyle = "#dde2ea";
  ctx.fillStyle = "#556";
  ctx.lineWidth = 1;
  ctx.textAlign = "right";
  ctx.textBaseline = "middle";
  for (const v of ticks(s.lo, s.hi)) {
    ctx.beginPath();
    ctx.moveTo(box.x, s.y(v));
    ctx.lineTo(box.x + box.w, s.y(v));
    ctx.stroke();
    ctx.fillText(formatTick(v), box.x - 4, s.y(v));
  }
  ctx.textAlign = "center";
  ctx.textBaseline = "top";
  for (const t of ticks(0, s.tEnd)) ctx.fillText(formatTick(t), s.x(t), box.y + box.h + 3);
  ctx.strokeStyle = "#99a";
  ctx.setLineDash([3, 3]);
  for (const t of chart.marks) {
    ctx.beginPath();
    ctx.moveTo(s.x(t), box.y);
    ctx.lineTo(s.x(t), box.y + box.h);
    ctx.stroke();
  }
  ctx.setLineDash([]);
  ctx.strokeRect(box.x, box.y, box.w, box.h);
  ctx.textAlign = "right";
  ctx.fillText("t (s)", box.x + box.w, box.y + box.h + 14);
  ctx.textAlign = "left";
  ctx.fillStyle = "#1d2430";
  ctx.fillText(`${chart.title} (${chart.unit})`, box.x, 3);
}

function formatTick(v: number): string {
  return Number(v.toPrecision(3)).toString();
}
