import { mkdirSync, mkdtempSync, symlinkSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { describe, expect, it } from "vitest";
import { confine, contentType, isTwinFile } from "./static-files.js";

describe("static files", () => {
  const base = mkdtempSync(join(tmpdir(), "robwot-static-"));
  const root = join(base, "twin");
  mkdirSync(join(root, "meshes"), { recursive: true });
  writeFileSync(join(root, "meshes", "a.stl"), "x");
  writeFileSync(join(root, "..", "outside-secret.txt"), "secret");
  symlinkSync(join(root, "..", "outside-secret.txt"), join(root, "meshes", "link.stl"));

  it.each(["meshes/a.stl", "/meshes//a.stl"])("resolves %s inside the root", (rel) => {
    expect(confine(root, rel)).toBe(join(root, "meshes", "a.stl"));
  });

  it.each(["../outside-secret.txt", "meshes/../../outside-secret.txt", "meshes\\a.stl", "meshes/link.stl", "meshes", "nope.stl", "a\0b"])(
    "refuses %j",
    (rel) => {
      expect(confine(root, rel)).toBeNull();
    },
  );

  it.each([
    ["robot.urdf", "application/urdf+xml"],
    ["workspace.csv", "text/csv"],
    ["workspace.stl", "model/stl"],
    ["meshes/link.DAE", "model/vnd.collada+xml"],
    ["viewer.js", "text/javascript; charset=utf-8"],
    ["blob.bin", "application/octet-stream"],
  ])("serves %s as %s", (file, type) => expect(contentType(file)).toBe(type));

  it("serves only the linked files of a twin folder", () => {
    expect(isTwinFile("robot.urdf", "robot.urdf")).toBe(true);
    expect(isTwinFile("meshes/x.stl", "robot.urdf")).toBe(true);
    expect(isTwinFile("twin.json", "robot.urdf")).toBe(true);
    expect(isTwinFile("reachability.csv", "robot.urdf")).toBe(true);
    expect(isTwinFile("td.json", "robot.urdf")).toBe(false);
    expect(isTwinFile("calibration.json", "robot.urdf")).toBe(false);
  });
});
