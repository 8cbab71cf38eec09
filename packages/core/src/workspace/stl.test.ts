import { describe, expect, it } from "vitest";
import { StlError } from "../errors.js";
import { box, icosphere } from "../test-support/shapes.js";
import { parseStl, triangleNormal, writeStl } from "./stl.js";

describe("STL", () => {
  const sphere = icosphere(2, 0.5, [0.1, -0.2, 0.3]);

  it.each(["binary", "ascii"] as const)("round-trips %s (float32 precision)", (format) => {
    const bytes = writeStl(sphere, { format, name: "ws" });
    const mesh = parseStl(bytes);
    expect(mesh.format).toBe(format);
    expect(mesh.triangles.length).toBe(sphere.length);
    for (let i = 0; i < sphere.length; i++) expect(Math.abs(mesh.triangles[i]! - sphere[i]!)).toBeLessThan(1e-6);
    const n0 = triangleNormal(sphere, 0);
    for (let k = 0; k < 3; k++) expect(mesh.normals[k]).toBeCloseTo(n0[k]!, 5);
  });

  it("binary size is 84 + 50 n and accepts ArrayBuffer, Buffer and views", () => {
    const bytes = writeStl(box([0, 0, 0], [1, 1, 1]));
    expect(bytes.byteLength).toBe(84 + 50 * 12);
    expect(parseStl(bytes.buffer).triangles.length).toBe(108);
    expect(parseStl(Buffer.from(bytes)).triangles.length).toBe(108);
  });

  it("writes outward normals for outward winding", () => {
    const mesh = parseStl(writeStl(box([-1, -1, -1], [1, 1, 1])));
    for (let t = 0; t < 12; t++) {
      const c = [0, 1, 2].map((k) => (mesh.triangles[9 * t + k]! + mesh.triangles[9 * t + 3 + k]! + mesh.triangles[9 * t + 6 + k]!) / 3);
      const dot = c[0]! * mesh.normals[3 * t]! + c[1]! * mesh.normals[3 * t + 1]! + c[2]! * mesh.normals[3 * t + 2]!;
      expect(dot).toBeGreaterThan(0);
    }
  });

  it("rejects a truncated binary file with sizes in the message", () => {
    const bytes = writeStl(sphere).subarray(0, 84 + 50 * 3 + 7);
    expect(() => parseStl(bytes, { file: "w.stl" })).toThrow(/w\.stl: binary STL declares 320 triangles .* has 241 bytes/);
  });

  it.each([
    ["vertex outside a facet", "solid x\nvertex 0 0 0\nendsolid x\n", /:2: 'vertex' outside a facet/],
    ["bad number", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 a 0\n", /:4: expected 3 finite numbers/],
    ["two vertices", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\n", /:7: facet ends with 2 vertices/],
    ["truncated", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", /ends inside a facet/],
    ["garbage", "hello", /neither a binary STL/],
  ])("rejects ASCII with %s, naming the line", (_label, text, message) => {
    expect(() => parseStl(new TextEncoder().encode(text), { file: "a.stl" })).toThrow(message);
    try {
      parseStl(new TextEncoder().encode(text));
    } catch (e) {
      expect(e).toBeInstanceOf(StlError);
      expect((e as StlError).code).toBe("E_BAD_STL");
    }
  });
});
