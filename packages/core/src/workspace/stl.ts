/**
 * STL read/write (binary and ASCII). Triangles are a flat Float64Array, 9 numbers per triangle
 * (v0 xyz, v1 xyz, v2 xyz), counter-clockwise seen from outside (outward normal by the right-hand rule).
 * Pure (browser-safe).
 */
import { StlError } from "../errors.js";
import { snippet } from "../snippet.js";
import { TWIN_FILES } from "../twin-layout.js";

export interface StlMesh {
  /** 9 per triangle, metres */
  triangles: Float64Array;
  /** stored facet normals, 3 per triangle (may be zero in files that omit them) */
  normals: Float64Array;
  format: "binary" | "ascii";
  /** ASCII solid name or binary header text (trimmed) */
  name: string;
}

function asBytes(data: ArrayBufferLike | ArrayBufferView): Uint8Array {
  if (data instanceof Uint8Array) return data;
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  return new Uint8Array(data);
}

export function parseStl(data: ArrayBufferLike | ArrayBufferView, options: { file?: string } = {}): StlMesh {
  const file = options.file ?? TWIN_FILES.surface;
  const bytes = asBytes(data);
  if (bytes.byteLength >= 84) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const n = view.getUint32(80, true);
    if (84 + 50 * n === bytes.byteLength) return parseBinary(bytes, view, n, file);
  }
  const head = new TextDecoder().decode(bytes.subarray(0, Math.min(bytes.byteLength, 512)));
  if (/^\s*solid\b/.test(head)) return parseAscii(new TextDecoder().decode(bytes), file);
  if (bytes.byteLength >= 84) {
    const n = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength).getUint32(80, true);
    throw new StlError(`${file}: binary STL declares ${n} triangles (${84 + 50 * n} bytes) but has ${bytes.byteLength} bytes (truncated or not an STL)`, {
      file,
      triangles: n,
      expectedBytes: 84 + 50 * n,
      bytes: bytes.byteLength,
    });
  }
  throw new StlError(`${file}: ${bytes.byteLength} bytes is neither a binary STL (>= 84 bytes) nor ASCII ('solid ...')`, { file, bytes: bytes.byteLength });
}

function parseBinary(bytes: Uint8Array, view: DataView, n: number, file: string): StlMesh {
  const triangles = new Float64Array(9 * n);
  const normals = new Float64Array(3 * n);
  for (let t = 0; t < n; t++) {
    const off = 84 + 50 * t;
    for (let k = 0; k < 3; k++) normals[3 * t + k] = view.getFloat32(off + 4 * k, true);
    for (let k = 0; k < 9; k++) {
      const v = view.getFloat32(off + 12 + 4 * k, true);
      if (!Number.isFinite(v)) throw new StlError(`${file}: triangle ${t} has a non-finite coordinate`, { file, triangle: t, offset: off + 12 + 4 * k });
      triangles[9 * t + k] = v;
    }
  }
  const name = new TextDecoder().decode(bytes.subarray(0, 80)).replace(/\0+$/, "").trim();
  return { triangles, normals, format: "binary", name };
}

function parseAscii(text: string, file: string): StlMesh {
  const tris: number[] = [];
  const norms: number[] = [];
  const lines = text.split(/\r?\n/);
  let name = "";
  let vertices = 0;
  let inFacet = false;
  const fail = (line: number, msg: string): never => {
    throw new StlError(`${file}:${line}: ${msg}`, { file, line });
  };
  const nums = (parts: string[], from: number, line: number): number[] => {
    const out = parts.slice(from, from + 3).map(Number);
    if (out.length !== 3 || out.some((v) => !Number.isFinite(v))) fail(line, `expected 3 finite numbers, got '${snippet(parts.slice(from).join(" "))}'`);
    return out;
  };
  for (let i = 0; i < lines.length; i++) {
    const lineNo = i + 1;
    const parts = lines[i]!.trim().split(/\s+/);
    const kw = parts[0]?.toLowerCase() ?? "";
    if (kw === "") continue;
    if (kw === "solid") {
      if (!name) name = parts.slice(1).join(" ");
    } else if (kw === "facet") {
      if (inFacet) fail(lineNo, "'facet' inside a facet");
      if (parts[1]?.toLowerCase() !== "normal") fail(lineNo, "expected 'facet normal nx ny nz'");
      norms.push(...nums(parts, 2, lineNo));
      inFacet = true;
      vertices = 0;
    } else if (kw === "vertex") {
      if (!inFacet) fail(lineNo, "'vertex' outside a facet");
      if (++vertices > 3) fail(lineNo, "more than 3 vertices in a facet");
      tris.push(...nums(parts, 1, lineNo));
    } else if (kw === "endfacet") {
      if (!inFacet || vertices !== 3) fail(lineNo, `facet ends with ${vertices} vertices, expected 3`);
      inFacet = false;
    } else if (kw !== "outer" && kw !== "endloop" && kw !== "endsolid") {
      fail(lineNo, `unexpected '${snippet(parts[0])}'`);
    }
  }
  if (inFacet) fail(lines.length, "file ends inside a facet (truncated)");
  return { triangles: Float64Array.from(tris), normals: Float64Array.from(norms), format: "ascii", name };
}

/** Unit normal of triangle t by the right-hand rule (zero for a degenerate triangle). */
export function triangleNormal(tri: ArrayLike<number>, t: number): [number, number, number] {
  const o = 9 * t;
  const ux = tri[o + 3]! - tri[o]!, uy = tri[o + 4]! - tri[o + 1]!, uz = tri[o + 5]! - tri[o + 2]!;
  const vx = tri[o + 6]! - tri[o]!, vy = tri[o + 7]! - tri[o + 1]!, vz = tri[o + 8]! - tri[o + 2]!;
  const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
  const len = Math.hypot(nx, ny, nz);
  return len > 0 ? [nx / len, ny / len, nz / len] : [0, 0, 0];
}

/** Writes binary STL (default) or ASCII; facet normals computed from the vertex order. */
export function writeStl(triangles: ArrayLike<number>, options: { format?: "binary" | "ascii"; name?: string } = {}): Uint8Array {
  if (triangles.length % 9 !== 0) {
    throw new StlError(`triangles has ${triangles.length} numbers, not a multiple of 9`, { got: triangles.length });
  }
  const n = triangles.length / 9;
  const name = options.name ?? "robwot";
  if (options.format === "ascii") {
    const out: string[] = [`solid ${name}`];
    for (let t = 0; t < n; t++) {
      out.push(`  facet normal ${triangleNormal(triangles, t).join(" ")}`, "    outer loop");
      for (let k = 0; k < 3; k++) out.push(`      vertex ${triangles[9 * t + 3 * k]} ${triangles[9 * t + 3 * k + 1]} ${triangles[9 * t + 3 * k + 2]}`);
      out.push("    endloop", "  endfacet");
    }
    out.push(`endsolid ${name}`);
    return new TextEncoder().encode(out.join("\n") + "\n");
  }
  const bytes = new Uint8Array(84 + 50 * n);
  const header = new TextEncoder().encode(`binary STL ${name}`.slice(0, 80));
  bytes.set(header.subarray(0, 80));
  const view = new DataView(bytes.buffer);
  view.setUint32(80, n, true);
  for (let t = 0; t < n; t++) {
    const off = 84 + 50 * t;
    const nn = triangleNormal(triangles, t);
    for (let k = 0; k < 3; k++) view.setFloat32(off + 4 * k, nn[k]!, true);
    for (let k = 0; k < 9; k++) view.setFloat32(off + 12 + 4 * k, triangles[9 * t + k]!, true);
  }
  return bytes;
}
