"""Alpha shape of a 3-D point cloud: Delaunay tetrahedra kept when their circumradius <= alpha.

The surface is the set of faces belonging to exactly one kept tetrahedron, each oriented outward (away
from the kept tetrahedron's fourth vertex). Edges where the kept set touches itself only along an edge
(non-manifold) are repaired by also keeping the tetrahedra around that edge, so the surface is closed
and every edge is shared by exactly two faces. The volume is the sum of the kept tetrahedra's volumes.

``alpha="auto"`` rule (local, from the data): a tetrahedron is kept when its circumradius is at most
the largest of its vertices' radii, a vertex's radius being ``LOCAL_FACTOR`` (2) x the distance to its
``AUTO_K``-th (8th) nearest neighbour. A joint-space-uniform cloud is dense in some regions and sparse in
others; a single radius large enough to fill the sparse regions bridges every gap in the dense ones (it
filled the 5 cm cavity of the shell test robot below 80,000 samples). Locally a gap stays open when it is
wider than about four sample spacings around it. Measured on analytic clouds (alpha_shape tests): the
shell (radii 5-25 cm, uniform in radius and angles) keeps its cavity empty at 20,000 and 80,000 samples
(at 5,000 the cavity is only 2-3 spacings wide and fills); volumes -11.5 / -7.1 / -4.0 % (shell) and
-8.3 / -5.0 / -3.2 % (box) at 5k / 20k / 80k: samples never reach the true boundary, so shapes come out
slightly small. ``alpha`` in the result is the median vertex radius (of at most ``RADIUS_SAMPLE`` of
them). A number instead of ``"auto"`` is one radius for every tetrahedron (the classic alpha shape).

Speed: before the triangulation, points deep inside the cloud are thinned to one per voxel of side
``h = s / sqrt(3)``, ``s`` being the radius (one given) or the 99th percentile of the vertex radii
(auto): an empty ball centred in an occupied voxel has a radius below ``sqrt(3) h <= s``, so a
tetrahedron there is kept when a deep voxel's representative counts with radius ``s``. Points within
``thin_layers`` voxels of an empty voxel are all kept, so a cavity holding an empty voxel is carved as
without thinning. With one radius and 2 layers the surface is exactly the one without thinning; the
default 1 layer triangulates 2-4x fewer points and changed the volume by < 0.02 % on the test clouds
(kuka, auto: identical to 1e-6). The percentile: larger voxels leave fewer points (more of the sparse
regions' voxels are deep); at 877,000 kuka FK points the 95th / 98th / 99th / 100th percentile left
247k / 192k / 169k / 228k points, the 99th in 7.8 s instead of 11.2 s (the 100th, an outlier's radius,
changed the volume by 1 %). Against no thinning (``thin_layers=0``), with the radii's sample below: the
95th percentile -0.0002 % of volume and 0 of 300,000 random points of the box classified otherwise, the
99th -0.001 % and 4 of 300,000 (all inside without thinning, outside with it). The tetrahedralisation
is ``delaunay.py``'s: only tetrahedra smaller than the largest vertex radius (no other can be kept), in
slabs on all cores, the same for any number of slabs (877,000 kuka points, 95th percentile: 14.3 s in one
triangulation, 10.7 s in two slabs on 2 cores).

Flat point sets (coplanar as for a planar robot, collinear) have no 3-D alpha shape: they
get the thickened description of ``flat_shape.py`` (``method`` ``"planar-alpha-shape"`` or
``"flat-hull"``). Fallback: when Qhull fails, no tetrahedron survives or there is no point at all, the
convex hull is used (``method == "convex-hull"``; empty for fewer than 2 points) and ``warning`` says
why.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError, cKDTree

from robwot_sim.workspace.delaunay import Tetrahedra, small_tetrahedra
from robwot_sim.workspace.flat_shape import FlatShape, flat_shape
from robwot_sim.workspace.mesh import boundary_faces, fill_nonmanifold_edges

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

AUTO_K = 8
LOCAL_FACTOR = 2.0
THIN_QUANTILE = 0.99
_PLANAR_RTOL = 1e-9
THIN_LAYERS = 1
# The median and the thinning quantile of the radii come from at most this many points (every k-th): only
# the triangulated points need their own radius (877,000 kuka points: the radii of all took 2.2 s; every 4th
# point gave a median and 99th percentile within 0.3 % of those of all, every 9th a median within 0.05 %).
RADIUS_SAMPLE = 100_000
_THIN_MAX_CELLS = 20_000_000


@dataclass(frozen=True)
class AlphaShape:
    """A closed, outward-oriented triangle surface with its enclosed volume (m^3)."""

    vertices: FloatArray
    triangles: IntArray
    volume: float
    alpha: float | None
    method: str
    warning: str | None = None
    _tets: Tetrahedra | None = field(default=None, repr=False)
    _kept: BoolArray | None = field(default=None, repr=False)
    _hull_eq: FloatArray | None = field(default=None, repr=False)

    def contains(self, points: npt.ArrayLike) -> BoolArray:
        """Whether each point ``(n, 3)`` lies inside the shape (kept tetrahedra or hull half-spaces)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        if self._tets is not None and self._kept is not None:
            s = self._tets.locate(p)
            inside: BoolArray = (s >= 0) & self._kept[np.maximum(s, 0)]
            return inside
        if self._hull_eq is not None and self.volume > 0.0:
            scale = float(np.abs(self.vertices).max()) if self.vertices.size else 1.0
            d = p @ self._hull_eq[:, :3].T + self._hull_eq[:, 3]
            return np.asarray(np.all(d <= 1e-12 * scale, axis=1))
        return np.zeros(len(p), dtype=bool)


def local_radii(points: FloatArray, at: FloatArray | None = None, tree: cKDTree | None = None) -> FloatArray:
    """Per point of ``at`` (default: every point), its ``alpha="auto"`` radius (m): ``LOCAL_FACTOR`` x the
    distance to its ``AUTO_K``-th nearest neighbour among ``points`` (module docstring); ``tree``: a
    ``cKDTree`` of ``points`` already built."""
    query = points if at is None else at
    k = min(AUTO_K, len(points) - 1)
    if k < 1:
        return np.zeros(len(query))
    tree = cKDTree(points) if tree is None else tree
    d, _ = tree.query(query, k=[k + 1], workers=-1)  # k+1: the point itself first
    radii: FloatArray = LOCAL_FACTOR * d[:, 0]
    return radii


def auto_alpha(points: FloatArray) -> float:
    """The median of ``local_radii`` (m): the radius reported for ``alpha="auto"`` and the scale of the
    interior thinning."""
    return float(np.median(local_radii(points))) if len(points) > 1 else 0.0


def _erode(grid: BoolArray, iterations: int) -> BoolArray:
    """Binary erosion by the 3x3x3 cube (a cell stays when its 26 neighbours are set); the border of the
    grid is padded with empty cells by the caller."""
    out = grid
    for _ in range(iterations):
        g = out
        core = g[1:-1, 1:-1, 1:-1].copy()
        for dx in (0, 1, 2):
            for dy in (0, 1, 2):
                for dz in (0, 1, 2):
                    core &= g[dx:dx + g.shape[0] - 2, dy:dy + g.shape[1] - 2, dz:dz + g.shape[2] - 2]
        out = np.zeros_like(g)
        out[1:-1, 1:-1, 1:-1] = core
    return out


def thin_interior(points: FloatArray, alpha: float, layers: int = THIN_LAYERS) -> tuple[BoolArray, BoolArray]:
    """Points to keep and, among them, the representatives of deep voxels (module docstring); ``layers``
    = 0 keeps all."""
    h = alpha / np.sqrt(3.0) * 0.999
    none = np.zeros(len(points), dtype=bool)
    if layers < 1 or not (h > 0 and np.isfinite(h)) or len(points) < 1000:
        return ~none, none
    pad = layers + 1
    ijk = np.floor((points - points.min(axis=0)) / h).astype(np.int64) + pad
    dims = ijk.max(axis=0) + pad + 1
    if float(np.prod(dims.astype(np.float64))) > _THIN_MAX_CELLS:
        return ~none, none
    key = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    occupied = np.zeros(int(np.prod(dims)), dtype=bool)
    occupied[key] = True
    deep = _erode(occupied.reshape(tuple(int(d) for d in dims)), layers).ravel()[key]
    keep = ~deep
    _, first = np.unique(key, return_index=True)
    keep[first] = True
    return keep, keep & deep


def alpha_shape(points: npt.ArrayLike, alpha: float | str = "auto", *,
                thin_layers: int = THIN_LAYERS) -> AlphaShape | FlatShape:
    """Alpha shape of ``points`` (``(n, 3)``, metres) with radius ``alpha`` (m) or ``"auto"``; a flat
    point set (planar robot, one joint) gives its thickened ``FlatShape`` (``flat_shape.py``).

    ``thin_layers``: interior thinning (module docstring); 0 = off, 2 = exact, 1 = default."""
    p = _distinct(np.asarray(points, dtype=np.float64).reshape(-1, 3))
    if len(p) <= 1:
        return convex_hull(p, f"{len(p)} distinct points: the end link reaches no point or a single one "
                              "(check the end-effector link)", None)
    rank = _affine_rank(p)
    if rank < 3:
        return flat_shape(p, rank, None if alpha == "auto" else float(alpha), local_radii)
    # an unbalanced tree (sliding midpoint) builds in 0.3 s instead of 0.5 s for 877,000 points, queries alike
    tree = cKDTree(p, balanced_tree=False) if alpha == "auto" else None
    if tree is not None:
        spread = local_radii(p, p[::-(-len(p) // RADIUS_SAMPLE)], tree)
        a, thin_scale = float(np.median(spread)), float(np.quantile(spread, THIN_QUANTILE))
    else:
        a = thin_scale = float(alpha)
    keep, deep = thin_interior(p, thin_scale, thin_layers)
    p_all, p = p, p[keep]
    if tree is None:
        vertex_radius = np.full(len(p), a)
    else:
        vertex_radius = local_radii(p_all, p, tree)
        vertex_radius[deep[keep]] = np.maximum(vertex_radius[deep[keep]], thin_scale)
    try:
        # only tetrahedra no larger than the largest vertex radius can be kept
        tets = small_tetrahedra(p, float(vertex_radius.max()) * (1.0 + 1e-9))
    except QhullError as exc:
        return convex_hull(p, f"Delaunay triangulation failed ({str(exc).splitlines()[0]})", a)
    kept = tets.radius <= vertex_radius[tets.simplices].max(axis=1)
    if not kept.any():
        return convex_hull(p, f"no tetrahedron has a circumradius <= alpha = {a:.6g} m", a)
    kept = fill_nonmanifold_edges(tets.simplices, tets.neighbors, kept)
    faces = boundary_faces(p, tets.simplices, tets.neighbors, kept)
    return AlphaShape(p, faces, float(tets.volume[kept].sum()), a, "alpha-shape", None, tets, kept)


def _distinct(p: FloatArray) -> FloatArray:
    """The distinct rows of ``p``, first occurrences in their order. Rows with distinct hashes of their bits
    are distinct, which settles the usual case (no duplicate) in 0.03 s for 877,000 rows; ``np.unique``'s
    lexicographic sort of three columns took 0.9-1.1 s."""
    p = p + 0.0  # -0.0 -> 0.0: equal values, equal bits
    b = np.ascontiguousarray(p).view(np.uint64)
    h = np.sort((b[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (b[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F))
                ^ b[:, 2])
    if not (h[1:] == h[:-1]).any():
        return p
    _, first = np.unique(p, axis=0, return_index=True)
    out: FloatArray = p[np.sort(first)]
    return out


def _affine_rank(p: FloatArray) -> int:
    """Dimension of the affine hull of ``p`` (0 = one point, 2 = coplanar), relative to its extent."""
    sv = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    if len(sv) == 0 or sv[0] == 0.0:
        return 0
    return int((sv > _PLANAR_RTOL * sv[0]).sum())


def convex_hull(p: FloatArray, reason: str, alpha: float | None) -> AlphaShape:
    """Convex-hull fallback (joggled with ``QJ`` so flat clouds still give a closed surface)."""
    warning = f"alpha shape degenerate, fell back to the convex hull: {reason}"
    empty = np.zeros((0, 3), dtype=np.int64)
    if len(p) < 4:
        return AlphaShape(p, empty, 0.0, alpha, "convex-hull", warning)
    try:
        hull = ConvexHull(p, qhull_options="QJ")
    except QhullError as exc:
        return AlphaShape(p, empty, 0.0, alpha, "convex-hull",
                          f"{warning}; the hull failed too ({str(exc).splitlines()[0]})")
    tris = np.asarray(hull.simplices, dtype=np.int64).copy()
    eq = np.asarray(hull.equations, dtype=np.float64)
    v = p[tris]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    flip = np.einsum("ij,ij->i", n, eq[:, :3]) < 0
    tris[flip] = tris[flip][:, [0, 2, 1]]
    return AlphaShape(p, tris, float(hull.volume), alpha, "convex-hull", warning, _hull_eq=eq)
