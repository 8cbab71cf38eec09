/**
 * `workspace.csv` (Contract 2): header `x,y,z,collision_free[,<joint>...]`, one row per sampled
 * configuration; x, y, z in metres (world frame), collision_free 1 or 0, joint values in rad or m.
 * Pure (browser-safe).
 */
import { CsvError } from "../errors.js";
import { snippet } from "../snippet.js";
import { TWIN_FILES } from "../twin-layout.js";

export interface WorkspaceCloud {
  /** x, y, z per point (length 3n), metres */
  points: Float64Array;
  /** 1 = collision-free, 0 = colliding (length n) */
  collisionFree: Uint8Array;
  /** joint column names, when the CSV has joint columns */
  jointNames?: string[];
  /** joint values row-major (length n * jointNames.length) */
  joints?: Float64Array;
}

const REQUIRED = ["x", "y", "z", "collision_free"] as const;

export interface ParseCsvOptions {
  /** file name used in error messages */
  file?: string;
}

/** A CSV of numbers: header, then `rows` × header.length finite values (row-major). */
export interface NumericTable {
  header: string[];
  rows: number;
  values: Float64Array;
}

/**
 * Reads a CSV of finite numbers whose header starts with `required` (more columns allowed only when
 * `extra`); every error names the file, the line and the column.
 */
export function parseNumericCsv(text: string, file: string, required: readonly string[], extra = false): NumericTable {
  const src = text.charCodeAt(0) === 0xfeff ? text.slice(1) : text;
  const lines = src.split(/\r?\n/);
  while (lines.length > 0 && lines[lines.length - 1]!.trim() === "") lines.pop();
  if (lines.length === 0) throw new CsvError(`${file}: empty file, expected header ${required.join(",")}`, { file, line: 1 });
  const header = lines[0]!.split(",").map((h) => h.trim());
  for (let i = 0; i < required.length; i++) {
    if (header[i] !== required[i]) {
      throw new CsvError(`${file}:1: header column ${i + 1} is '${snippet(header[i] ?? "")}', expected '${required[i]}' (header must start with ${required.join(",")})`, {
        file,
        line: 1,
        column: i + 1,
        got: header[i] === undefined ? null : snippet(header[i]),
        expected: required[i],
      });
    }
  }
  if (!extra && header.length > required.length) {
    throw new CsvError(`${file}:1: header has ${header.length} columns, expected ${required.join(",")}`, { file, line: 1, got: header.length, expected: required.length });
  }
  const width = header.length;
  const rows = lines.length - 1;
  const values = new Float64Array(rows * width);
  for (let r = 0; r < rows; r++) {
    const lineNo = r + 2;
    const fields = lines[r + 1]!.split(",");
    if (fields.length !== width) {
      throw new CsvError(`${file}:${lineNo}: ${fields.length} fields, expected ${width} (${snippet(header.join(","), 80)})`, { file, line: lineNo, got: fields.length, expected: width });
    }
    for (let c = 0; c < width; c++) {
      const raw = fields[c]!.trim();
      const v = raw === "" ? NaN : Number(raw);
      if (!Number.isFinite(v)) {
        throw new CsvError(`${file}:${lineNo}: column '${snippet(header[c])}' is '${snippet(raw)}', not a finite number`, { file, line: lineNo, column: snippet(header[c]), value: snippet(raw) });
      }
      values[r * width + c] = v;
    }
  }
  return { header, rows, values };
}

export function parseWorkspaceCsv(text: string, options: ParseCsvOptions = {}): WorkspaceCloud {
  const file = options.file ?? TWIN_FILES.pointCloud;
  const { header, rows: n, values } = parseNumericCsv(text, file, REQUIRED, true);
  const jointNames = header.slice(REQUIRED.length);
  const dupe = jointNames.find((name, i) => name === "" || jointNames.indexOf(name) !== i);
  if (dupe !== undefined) {
    throw new CsvError(`${file}:1: joint column name '${snippet(dupe)}' is empty or repeated`, { file, line: 1, got: snippet(dupe) });
  }
  const width = header.length;
  const points = new Float64Array(3 * n);
  const collisionFree = new Uint8Array(n);
  const joints = jointNames.length > 0 ? new Float64Array(n * jointNames.length) : undefined;
  for (let r = 0; r < n; r++) {
    const row = values.subarray(r * width, (r + 1) * width);
    points.set(row.subarray(0, 3), 3 * r);
    const flag = row[3]!;
    if (flag !== 0 && flag !== 1) {
      throw new CsvError(`${file}:${r + 2}: collision_free is '${flag}', expected 0 or 1`, { file, line: r + 2, column: "collision_free", value: String(flag) });
    }
    collisionFree[r] = flag;
    if (joints) joints.set(row.subarray(4), r * jointNames.length);
  }
  const cloud: WorkspaceCloud = { points, collisionFree };
  if (joints) {
    cloud.jointNames = jointNames;
    cloud.joints = joints;
  }
  return cloud;
}

/** Inverse of parseWorkspaceCsv; numbers are written with round-trip precision. Ends with a newline. */
export function writeWorkspaceCsv(cloud: WorkspaceCloud): string {
  const n = cloud.collisionFree.length;
  if (cloud.points.length !== 3 * n) {
    throw new CsvError(`points has ${cloud.points.length} values, expected 3 × ${n}`, { got: cloud.points.length, expected: 3 * n });
  }
  const names = cloud.jointNames ?? [];
  const m = names.length;
  if (m > 0 && (!cloud.joints || cloud.joints.length !== n * m)) {
    throw new CsvError(`joints must hold ${n} × ${m} values`, { got: cloud.joints?.length ?? 0, expected: n * m });
  }
  const out: string[] = [[...REQUIRED, ...names].join(",")];
  for (let i = 0; i < n; i++) {
    let row = `${cloud.points[3 * i]},${cloud.points[3 * i + 1]},${cloud.points[3 * i + 2]},${cloud.collisionFree[i] ? 1 : 0}`;
    for (let j = 0; j < m; j++) row += `,${cloud.joints![i * m + j]}`;
    out.push(row);
  }
  return out.join("\n") + "\n";
}
