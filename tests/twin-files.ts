/**
 * Independent readers for the twin folder's files, used by the CLI end-to-end tests to check what
 * `robwot generate` wrote (deliberately not the core package's parsers, so a bug there cannot hide one).
 */
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";

export interface CsvCloud {
  header: string[];
  rows: number[][];
}

export function readCsv(file: string): CsvCloud {
  const lines = readFileSync(file, "utf8").split(/\r?\n/).filter((l) => l !== "");
  const header = (lines[0] ?? "").split(",");
  const rows = lines.slice(1).map((l) => l.split(",").map(Number));
  return { header, rows };
}

export interface StlCheck {
  triangles: number;
  /** Every undirected edge is shared by exactly two triangles. */
  closed: boolean;
  /** Every directed edge appears once and its reverse once (consistent winding). */
  consistent: boolean;
  /** Signed volume from the winding (positive = outward normals), m^3. */
  signedVolume: number;
  /** Share of stored normals agreeing with the winding's normal. */
  normalsAgree: number;
}

export function checkBinaryStl(file: string): StlCheck {
  const buf = readFileSync(file);
  if (buf.length < 84) throw new Error(`${file}: ${buf.length} bytes, too short for binary STL`);
  const n = buf.readUInt32LE(80);
  if (buf.length !== 84 + 50 * n) throw new Error(`${file}: size ${buf.length} != 84 + 50 * ${n} (not binary STL)`);
  const vertexId = new Map<string, number>();
  const id = (o: number): number => {
    const key = `${buf.readFloatLE(o)},${buf.readFloatLE(o + 4)},${buf.readFloatLE(o + 8)}`;
    let v = vertexId.get(key);
    if (v === undefined) {
      v = vertexId.size;
      vertexId.set(key, v);
    }
    return v;
  };
  const directed = new Map<string, number>();
  let volume = 0;
  let agree = 0;
  for (let t = 0; t < n; t++) {
    const o = 84 + 50 * t;
    const p = [0, 1, 2].map((k) => [0, 1, 2].map((c) => buf.readFloatLE(o + 12 + 12 * k + 4 * c)));
    const [a, b, c] = p as [number[], number[], number[]];
    const ab = [b[0]! - a[0]!, b[1]! - a[1]!, b[2]! - a[2]!];
    const ac = [c[0]! - a[0]!, c[1]! - a[1]!, c[2]! - a[2]!];
    const cross = [ab[1]! * ac[2]! - ab[2]! * ac[1]!, ab[2]! * ac[0]! - ab[0]! * ac[2]!, ab[0]! * ac[1]! - ab[1]! * ac[0]!];
    const stored = [buf.readFloatLE(o), buf.readFloatLE(o + 4), buf.readFloatLE(o + 8)];
    if (cross[0]! * stored[0]! + cross[1]! * stored[1]! + cross[2]! * stored[2]! > 0) agree++;
    volume += (a[0]! * (b[1]! * c[2]! - b[2]! * c[1]!) - a[1]! * (b[0]! * c[2]! - b[2]! * c[0]!) + a[2]! * (b[0]! * c[1]! - b[1]! * c[0]!)) / 6;
    const ids = [id(o + 12), id(o + 24), id(o + 36)];
    for (let k = 0; k < 3; k++) {
      const key = `${ids[k]}>${ids[(k + 1) % 3]}`;
      directed.set(key, (directed.get(key) ?? 0) + 1);
    }
  }
  let closed = true;
  let consistent = true;
  for (const [key, count] of directed) {
    const [u, v] = key.split(">");
    const reverse = directed.get(`${v}>${u}`) ?? 0;
    if (count + reverse !== 2) closed = false;
    if (count !== 1 || reverse !== 1) consistent = false;
  }
  return { triangles: n, closed, consistent, signedVolume: volume, normalsAgree: n > 0 ? agree / n : 0 };
}

interface TdValidationReport {
  report: { json: string | null; schema: string | null; defaults: string | null; jsonld: string | null; additional: string | null };
  details: Record<string, string | null>;
}

/** The official W3C WoT TD validator (thingweb playground), JSON-LD check off (needs the network). */
export async function officialTdValidation(tdText: string): Promise<{ result: TdValidationReport; log: string[] }> {
  const require = createRequire(import.meta.url);
  const { tdValidator } = require("@thing-description-playground/core") as {
    tdValidator: (td: string, log: (m: string) => void, opts: Record<string, boolean>) => Promise<TdValidationReport>;
  };
  const log: string[] = [];
  const result = await tdValidator(tdText, (m) => log.push(String(m)), { checkDefaults: true, checkJsonLd: false, checkTmConformance: false });
  return { result, log };
}
