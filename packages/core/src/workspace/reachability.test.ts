import { describe, expect, it } from "vitest";
import { CsvError } from "../errors.js";
import { ReachabilityMap } from "./reachability.js";

const HEADER = "x,y,z,samples,free,directions,index";

describe("ReachabilityMap", () => {
  const text = [HEADER, "-0.062500,0.062500,0.062500,1,1,1,0.015625", "0.062500,0.062500,0.062500,4,3,2,0.031250", "0.187500,0.062500,0.062500,2,0,0,0.000000", ""].join("\n");

  it("finds the voxel of a position (voxels aligned to the origin) and reports its index", () => {
    const map = ReachabilityMap.fromCsv(text, 0.125);
    expect(map.voxels.length).toBe(3);
    expect(map.check([0.01, 0.12, 0.0])).toEqual({ ok: true, index: 0.03125, samples: 4, free: 3, voxel: 0.125 });
    expect(map.check([-0.001, 0.1, 0.1])).toMatchObject({ ok: true, index: 0.015625, samples: 1 });
    // samples ended there, none collision-free
    expect(map.check([0.2, 0.1, 0.1])).toEqual({ ok: false, index: 0, samples: 2, free: 0, voxel: 0.125 });
    // no sample at all
    expect(map.check([0.0, -0.01, 0.1])).toEqual({ ok: false, index: 0, samples: 0, free: 0, voxel: 0.125 });
  });

  it.each([
    ["x,y,z,samples,free,index", 0.125, /header column 6 is 'index', expected 'directions'/],
    [`${HEADER}\n0.05,0.0625,0.0625,1,1,1,0.015625`, 0.125, /:2: 0.05 is not a voxel centre of a 0.125 m grid/],
    [`${HEADER}\n0.0625,0.0625,0.0625,1,2,1,0.015625`, 0.125, /:2: free is 2, expected an integer within 0..samples \(1\)/],
    [`${HEADER}\n0.0625,0.0625,0.0625,3,2,3,0.046875`, 0.125, /:2: directions is 3, expected an integer within 0..min\(64, free\)/],
    [`${HEADER}\n0.0625,0.0625,0.0625,3,2,2,0.5`, 0.125, /:2: index is 0.5, expected directions \/ 64 = 0.03125/],
    [`${HEADER}\n0.0625,0.0625,0.0625,0,0,0,0`, 0.125, /:2: samples is 0, expected an integer >= 1/],
    [`${HEADER}\n0.0625,0.0625,nan,1,1,1,0.015625`, 0.125, /:2: column 'z' is 'nan', not a finite number/],
    [`${HEADER},extra\n`, 0.125, /header has 8 columns/],
  ])("refuses a bad file with its line and reason (%#)", (csv, voxel, message) => {
    expect(() => ReachabilityMap.fromCsv(csv, voxel, { file: "reachability.csv" })).toThrow(CsvError);
    expect(() => ReachabilityMap.fromCsv(csv, voxel, { file: "reachability.csv" })).toThrow(message);
  });

  it("refuses a voxel side that is not a positive length", () => {
    expect(() => new ReachabilityMap(0, [])).toThrow(/positive number of metres/);
  });
});
