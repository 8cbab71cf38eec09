/** Console formatting shared by the scenarios: fixed-width tables and compact numbers. */

export function fmt(value: number, digits = 3): string {
  return Number.isFinite(value) ? value.toFixed(digits) : String(value);
}

export function fmtXyz(p: { x: number; y: number; z: number }, digits = 3): string {
  return `(${fmt(p.x, digits)}, ${fmt(p.y, digits)}, ${fmt(p.z, digits)})`;
}

export function fmtJoints(joints: Record<string, number>, digits = 3): string {
  return Object.entries(joints)
    .map(([k, v]) => `${k}=${fmt(v, digits)}`)
    .join(" ");
}

/** A plain-text table; every row must have as many cells as `header`. */
export function table(header: string[], rows: string[][]): string {
  const widths = header.map((h, i) => Math.max(h.length, ...rows.map((r) => (r[i] ?? "").length)));
  const line = (cells: string[]): string => cells.map((c, i) => c.padEnd(widths[i] ?? 0)).join("  ").trimEnd();
  return [line(header), line(widths.map((w) => "-".repeat(w))), ...rows.map(line)].join("\n");
}

/** Print the machine-readable summary line (`--json`): one line, prefixed so tests can find it. */
export function printJsonSummary(summary: unknown): void {
  console.log(`RESULT ${JSON.stringify(summary)}`);
}
