import { describe, expect, it } from "vitest";
import { CsvError } from "../errors.js";
import { parseWorkspaceCsv, writeWorkspaceCsv } from "./csv.js";

describe("workspace.csv", () => {
  it("round-trips points, labels and joint columns exactly", () => {
    const cloud = {
      points: Float64Array.from([0.1, -0.2, 0.30000000000000004, 1e-7, 2.5, -3]),
      collisionFree: Uint8Array.from([1, 0]),
      jointNames: ["j1", "j2"],
      joints: Float64Array.from([0.5, -1.25, Math.PI, -Math.PI / 3]),
    };
    const text = writeWorkspaceCsv(cloud);
    expect(text.split("\n")[0]).toBe("x,y,z,collision_free,j1,j2");
    expect(parseWorkspaceCsv(text)).toEqual(cloud);
  });

  it("reads CRLF, a BOM, spaces and no trailing newline; no joint columns", () => {
    const cloud = parseWorkspaceCsv("\ufeffx,y,z,collision_free\r\n1, 2 ,3,1\r\n4,5,6,0");
    expect(Array.from(cloud.points)).toEqual([1, 2, 3, 4, 5, 6]);
    expect(Array.from(cloud.collisionFree)).toEqual([1, 0]);
    expect(cloud.jointNames).toBeUndefined();
  });

  it.each([
    ["wrong header", "x,y,collision_free\n", /w\.csv:1: header column 3 is 'collision_free', expected 'z'/, 1],
    ["empty", "", /empty file/, 1],
    ["short row", "x,y,z,collision_free\n1,2,3,1\n1,2,3\n", /w\.csv:3: 3 fields, expected 4/, 3],
    ["not a number", "x,y,z,collision_free\n1,2,3,1\n1,abc,3,1\n", /w\.csv:3: column 'y' is 'abc'/, 3],
    ["NaN", "x,y,z,collision_free\nNaN,2,3,1\n", /w\.csv:2: column 'x' is 'NaN'/, 2],
    ["empty field", "x,y,z,collision_free\n1,,3,1\n", /column 'y' is ''/, 2],
    ["bad label", "x,y,z,collision_free\n1,2,3,2\n", /w\.csv:2: collision_free is '2', expected 0 or 1/, 2],
    ["repeated joint column", "x,y,z,collision_free,a,a\n", /'a' is empty or repeated/, 1],
  ])("rejects %s naming file and line", (_label, text, message, line) => {
    expect(() => parseWorkspaceCsv(text, { file: "w.csv" })).toThrow(message);
    try {
      parseWorkspaceCsv(text, { file: "w.csv" });
    } catch (e) {
      expect(e).toBeInstanceOf(CsvError);
      expect((e as CsvError).code).toBe("E_BAD_CSV");
      expect((e as CsvError).details).toMatchObject({ file: "w.csv", line });
    }
  });

  it("refuses to write inconsistent arrays", () => {
    expect(() => writeWorkspaceCsv({ points: new Float64Array(5), collisionFree: new Uint8Array(2) })).toThrow(/expected 3 × 2/);
  });
});
