/**
 * The workspace surface (`workspace.stl`) as a solid: point-in-mesh by ray parity along the three axes
 * (majority vote), each ray accelerated by a 2D grid of projected triangles; exact tie-breaking makes
 * rays through edges and vertices count once. Pure (browser-safe).
 */
import { InvalidArgumentError, StlError } from "../errors.js";
import type { Bounds, Vec3 } from "../types.js";
import { RayGrid } from "./ray-grid.js";
import { parseStl } from "./stl.js";
import { SurfaceDistanceGrid } from "./surface-distance.js";
import { meshTopology, signedVolume, type MeshTopology } from "./topology.js";

export class WorkspaceMesh {
  readonly triangles: Float64Array;
  readonly bounds: Bounds;
  private readonly grids: [RayGrid, RayGrid, RayGrid];
  private distanceGrid: SurfaceDistanceGrid | undefined;
  private topologyCache: MeshTopology | undefined;

  /** @param triangles 9 numbers per triangle (see stl.ts) */
  constructor(triangles: Float64Array) {
    if (triangles.length === 0 || triangles.length % 9 !== 0) {
      throw new StlError(`a workspace mesh needs at least one triangle (got ${triangles.length} numbers)`, { got: triangles.length });
    }
    this.triangles = triangles;
    const min: Vec3 = [Infinity, Infinity, Infinity];
    const max: Vec3 = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < triangles.length; i += 3) {
      for (let k = 0; k < 3; k++) {
        const v = triangles[i + k]!;
        if (v < min[k]!) min[k] = v;
        if (v > max[k]!) max[k] = v;
      }
    }
    this.bounds = { min, max };
    this.grids = [new RayGrid(triangles, 0, min, max), new RayGrid(triangles, 1, min, max), new RayGrid(triangles, 2, min, max)];
  }

  static fromStl(data: ArrayBufferLike | ArrayBufferView, options: { file?: string } = {}): WorkspaceMesh {
    return new WorkspaceMesh(parseStl(data, options).triangles);
  }

  get triangleCount(): number {
    return this.triangles.length / 9;
  }

  /** True when p is inside the closed surface (2 of 3 axis rays cross it an odd number of times). */
  contains(p: readonly number[]): boolean {
    const x = p[0], y = p[1], z = p[2];
    if (x === undefined || y === undefined || z === undefined || !Number.isFinite(x) || !Number.isFinite(y) || !Number.isFinite(z)) {
      throw new InvalidArgumentError(`point must be 3 finite numbers, got ${JSON.stringify(p)}`, { param: "p", expected: "[x, y, z]", got: p });
    }
    const { min, max } = this.bounds;
    if (x < min[0] || x > max[0] || y < min[1] || y > max[1] || z < min[2] || z > max[2]) return false;
    let votes = 0;
    for (const g of this.grids) votes += g.crossings(p) & 1;
    return votes >= 2;
  }

  /** Unsigned distance (m) from p to the surface. */
  distanceToSurface(p: readonly number[]): number {
    this.distanceGrid ??= new SurfaceDistanceGrid(this.triangles, this.bounds.min, this.bounds.max);
    return this.distanceGrid.distance(p);
  }

  /** Signed distance: negative inside, positive outside (m). */
  signedDistance(p: readonly number[]): number {
    const d = this.distanceToSurface(p);
    return this.contains(p) ? -d : d;
  }

  topology(): MeshTopology {
    this.topologyCache ??= meshTopology(this.triangles);
    return this.topologyCache;
  }

  /** Watertight: every edge is shared by exactly two triangles (vertices welded by exact coordinates). */
  isClosed(): boolean {
    const t = this.topology();
    return t.boundaryEdges === 0 && t.nonManifoldEdges === 0;
  }

  /** Closed, consistently wound, and the winding gives outward normals (positive volume). */
  isOutwardOriented(): boolean {
    return this.isClosed() && this.topology().misorientedEdges === 0 && this.volume() > 0;
  }

  /** Enclosed volume (m³); negative if the normals point inward. */
  volume(): number {
    return signedVolume(this.triangles);
  }
}
