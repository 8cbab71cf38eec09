import { mkdtemp, rm, writeFile } from "node:fs/promises";
import { createServer, type Server } from "node:http";
import type { AddressInfo } from "node:net";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { afterAll, beforeAll, describe, expect, it } from "vitest";
import { RobwotError } from "../errors.js";
import { ballPoints, icosphere, rng } from "../test-support/shapes.js";
import { writeWorkspaceCsv } from "./csv.js";
import { loadWorkspace } from "./load-fs.js";
import { loadWorkspaceFromUrls } from "./load-url.js";
import { writeStl } from "./stl.js";

let dir: string;
let server: Server;
let url: string;

beforeAll(async () => {
  dir = await mkdtemp(join(tmpdir(), "robwot-core-"));
  const points = ballPoints(3000, 0.9, rng(2));
  const free = new Uint8Array(3000).map((_, i) => (points[3 * i + 2]! < 0.5 ? 1 : 0));
  await writeFile(join(dir, "workspace.stl"), writeStl(icosphere(3, 0.92)));
  await writeFile(join(dir, "workspace.csv"), writeWorkspaceCsv({ points, collisionFree: free }));
  await writeFile(join(dir, "broken.csv"), "x,y,z,collision_free\n1,2,3,1\n1,2\n");
  server = createServer((req, res) => {
    const name = (req.url ?? "/").slice(1);
    import("node:fs/promises")
      .then((fs) => fs.readFile(join(dir, name)))
      .then((data) => res.writeHead(200).end(data))
      .catch(() => res.writeHead(404, "Not Found").end());
  });
  await new Promise<void>((resolve) => server.listen(0, "127.0.0.1", resolve));
  url = `http://127.0.0.1:${(server.address() as AddressInfo).port}/`;
});

afterAll(async () => {
  await new Promise((resolve) => server.close(resolve));
  await rm(dir, { recursive: true, force: true });
});

describe("loading a workspace", () => {
  it("from a twin folder answers inside/outside and the point-cloud score", async () => {
    const ws = await loadWorkspace(dir);
    expect(ws.mesh.isClosed()).toBe(true);
    expect(ws.cloud.collisionFree.length).toBe(3000);
    const low = ws.check([0, 0, -0.3]);
    expect(low).toMatchObject({ ok: true, insideWorkspace: true, pointCloud: { ok: true, share: 0 } });
    const high = ws.check([0, 0, 0.75]);
    expect(high.insideWorkspace).toBe(true);
    expect(high.pointCloud.share).toBe(1);
    expect(high.ok).toBe(false);
    expect(ws.check([0, 0, 1.5]).insideWorkspace).toBe(false);
  });

  it("over HTTP gives the same answers", async () => {
    const a = await loadWorkspace(dir);
    const b = await loadWorkspaceFromUrls(`${url}workspace.stl`, `${url}workspace.csv`);
    const r = rng(9);
    for (let i = 0; i < 200; i++) {
      const p = [0, 1, 2].map(() => 2 * r() - 1);
      expect(b.check(p)).toEqual(a.check(p));
    }
  });

  it("names the missing file", async () => {
    const err = await loadWorkspace(join(dir, "nope")).catch((e: unknown) => e);
    expect(err).toBeInstanceOf(RobwotError);
    expect((err as RobwotError).code).toBe("E_FILE_NOT_FOUND");
    expect((err as RobwotError).message).toMatch(/nope\/workspace\.(stl|csv): no such file/);
  });

  it("reports HTTP status and bad content with the URL", async () => {
    await expect(loadWorkspaceFromUrls(`${url}missing.stl`, `${url}workspace.csv`)).rejects.toThrow(/missing\.stl answered 404/);
    await expect(loadWorkspaceFromUrls(`${url}workspace.stl`, `${url}broken.csv`)).rejects.toThrow(/broken\.csv:3: 2 fields, expected 4/);
    await expect(loadWorkspaceFromUrls("http://127.0.0.1:1/workspace.stl", `${url}workspace.csv`)).rejects.toThrow(/cannot fetch/);
  });
});
