import { describe, expect, it } from "vitest";
import { meshProgress } from "./mesh-progress.js";
import { createProgress } from "./progress.js";

describe("meshProgress", () => {
  it("names the collision cache folder the backend writes to, then one line per mesh with its ETA", () => {
    let text = "";
    const stream = { write: (s: string) => ((text += s), true), isTTY: false } as unknown as NodeJS.WriteStream;
    const { onMesh, seen } = meshProgress(createProgress({ stream, tty: false, now: () => 0 }));
    expect(seen()).toBe(false);
    const base = { cache: "/srv/cache/robwot/collision", seconds: 0, parts: 0, elapsed: 0, eta: null, total: 2 };
    onMesh({ ...base, mesh: "", done: 0 });
    onMesh({ ...base, mesh: "link_2.stl", done: 1, parts: 3, seconds: 4, eta: null });
    onMesh({ ...base, mesh: "link_4.stl", done: 2, parts: 8, seconds: 54, eta: 0 });
    expect(seen()).toBe(true);
    expect(text.trim().split("\n")).toEqual([
      "robwot: first use of this robot: its 2 new collision mesh(es) are split into convex parts where concave, cached in /srv/cache/robwot/collision (and in the twin folder)",
      "robwot: decompose...",
      "robwot: decompose 1/2, ETA unknown: link_2.stl (3 convex parts, 4.0s)",
      "robwot: decompose 2/2: link_4.stl (8 convex parts, 54s)",
    ]);
  });
});
