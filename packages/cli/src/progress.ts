/**
 * Progress reporting on stderr: a redrawn bar with ETA on a terminal, plain lines otherwise (CI logs,
 * pipes), nothing at all in `--quiet`/`--json` mode. Stages are named by the caller.
 */

export interface ProgressSink {
  /** A stage starts (`load`, `sample`, `collide`, `alpha`, `write`, `td`). */
  stage(name: string): void;
  /** Progress within the current stage. */
  update(name: string, done: number, total: number): void;
  /** Free text (kept on its own line). */
  info(text: string): void;
  /** One step of a stage whose steps are uneven (a mesh decomposed): `text` says what was done, `eta` is
   * the caller's estimate of the time left (s; undefined when it gives none, null when it cannot tell
   * while steps remain). A redrawn line on a terminal, one plain line per step otherwise. */
  step(name: string, done: number, total: number, text: string, eta?: number | null): void;
  /** Clears the bar; call once at the end (`ok` false: the current stage did not finish). */
  end(ok?: boolean): void;
}

export interface ProgressOptions {
  stream?: NodeJS.WriteStream;
  /** Force TTY behaviour on or off (defaults to `stream.isTTY`). */
  tty?: boolean;
  silent?: boolean;
  now?: () => number;
}

const BAR_WIDTH = 28;

/** Seconds for people: tenths below ten, whole seconds below a minute, else minutes and seconds; rounded
 * once, before it is cut into minutes, so the seconds never read 60. */
export function formatDuration(seconds: number): string {
  if (!Number.isFinite(seconds) || seconds < 0) return "?";
  if (seconds < 9.95) return `${seconds.toFixed(1)}s`;
  const whole = Math.round(seconds);
  if (whole < 60) return `${whole}s`;
  return `${Math.floor(whole / 60)}m${String(whole % 60).padStart(2, "0")}s`;
}

/** An estimate of the time left while work remains: never printed as 0 (its least is a tenth). */
const timeLeft = (eta: number): string => formatDuration(Math.max(eta, 0.1));

export function createProgress(opts: ProgressOptions = {}): ProgressSink {
  const stream = opts.stream ?? process.stderr;
  const now = opts.now ?? (() => performance.now() / 1000);
  const tty = opts.tty ?? Boolean(stream.isTTY);
  if (opts.silent) {
    return { stage() {}, update() {}, info() {}, step() {}, end() {} };
  }
  let current: string | null = null;
  let stageStart = now();
  let lastPlainQuarter = -1;
  let barShown = false;
  let lastDraw = 0;

  const clearBar = (): void => {
    if (tty && barShown) {
      stream.write("\r\x1b[2K");
      barShown = false;
    }
  };
  const finishStage = (): void => {
    if (current === null) return;
    const took = formatDuration(now() - stageStart);
    clearBar();
    stream.write(`robwot: ${current} done in ${took}\n`);
    current = null;
  };

  return {
    stage(name) {
      finishStage();
      current = name;
      stageStart = now();
      lastPlainQuarter = -1;
      if (!tty) stream.write(`robwot: ${name}...\n`);
      else {
        stream.write(`\r\x1b[2K${name}...`);
        barShown = true;
      }
    },
    update(name, done, total) {
      if (name !== current) this.stage(name);
      const frac = total > 0 ? Math.min(1, Math.max(0, done / total)) : 0;
      const elapsed = now() - stageStart;
      const eta = frac > 0 ? (elapsed * (1 - frac)) / frac : Number.NaN;
      if (tty) {
        const t = now();
        if (t - lastDraw < 0.05 && frac < 1) return;
        lastDraw = t;
        const filled = Math.round(frac * BAR_WIDTH);
        const bar = "#".repeat(filled) + "-".repeat(BAR_WIDTH - filled);
        const pct = `${Math.floor(frac * 100)}`.padStart(3);
        stream.write(`\r\x1b[2K${name.padEnd(8)} [${bar}] ${pct}% ${done}/${total} ETA ${formatDuration(eta)}`);
        barShown = true;
      } else {
        const quarter = Math.floor(frac * 4);
        if (quarter > lastPlainQuarter && quarter < 4) {
          lastPlainQuarter = quarter;
          if (quarter > 0) stream.write(`robwot: ${name} ${done}/${total} (${quarter * 25}%, ETA ${formatDuration(eta)})\n`);
        }
      }
    },
    info(text) {
      clearBar();
      stream.write(`robwot: ${text}\n`);
    },
    step(name, done, total, text, eta) {
      if (name !== current) this.stage(name);
      const left = eta === undefined || done >= total ? "" : eta === null ? ", ETA unknown" : `, ETA ${timeLeft(eta)}`;
      if (tty) {
        stream.write(`\r\x1b[2K${name} ${done}/${total}${left}: ${text}`);
        barShown = true;
      } else {
        stream.write(`robwot: ${name} ${done}/${total}${left}: ${text}\n`);
      }
    },
    end(ok = true) {
      if (ok) finishStage();
      current = null;
      clearBar();
    },
  };
}

/**
 * Awaits `work`; if it is still running after `afterMs`, calls `say` once (e.g. to explain a wait the
 * progress bar cannot measure). The timer never outlives `work`.
 */
export async function whileSlow<T>(work: Promise<T>, afterMs: number, say: () => void): Promise<T> {
  const timer = setTimeout(say, afterMs);
  try {
    return await work;
  } finally {
    clearTimeout(timer);
  }
}
