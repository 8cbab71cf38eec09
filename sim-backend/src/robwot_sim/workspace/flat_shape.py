"""Workspaces without volume: a planar robot's (its end link moves in one plane), a single joint's (a
line or a curve). A solid through such points has no interior, so a closed surface
around them would reject every reachable target; instead the region they cover in their plane (or on
their line) is thickened by ``FLAT_HALF_THICKNESS`` (1 mm) on each side of it.

- Plane with an area: the 2-D alpha shape of the points in their plane (``method ==
  "planar-alpha-shape"``; the same local rule as the 3-D shape: a triangle is kept when its circumradius
  is at most the largest of its vertices' radii, 2 x the distance to the 8th nearest neighbour), as a
  prism of height 2 x 1 mm.
- Curve in a plane (no triangle survives: one revolute joint), line: the convex hull of the points
  in their plane grown by 1 mm in the plane (so the reachable points between two samples of a curve are
  inside too), thickened the same way (``method == "flat-hull"``; ``warning`` says what it is). For a
  curve this also accepts the points between the curve and its chord.

The frame is the points' principal axes (SVD): axis 0 along the largest extent, axis 2 normal to the
plane, right-handed. ``contains`` answers in that frame: within the thickness of the plane and inside a
kept triangle.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, Delaunay, QhullError

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

FLAT_HALF_THICKNESS = 1e-3  # m, on each side of the plane (and around a line or a point)


@dataclass(frozen=True)
class FlatShape:
    """A flat point set thickened into a closed, outward-oriented prism (module docstring)."""

    vertices: FloatArray
    triangles: IntArray
    volume: float
    alpha: float | None
    method: str
    warning: str | None
    half_thickness: float
    _centre: FloatArray
    _axes: FloatArray
    _triangulation: Delaunay
    _kept: BoolArray

    def contains(self, points: npt.ArrayLike) -> BoolArray:
        """Whether each point ``(n, 3)`` lies inside the prism."""
        local = (np.asarray(points, dtype=np.float64).reshape(-1, 3) - self._centre) @ self._axes.T
        s = self._triangulation.find_simplex(local[:, :2], tol=1e-9)  # samples on the outline count
        inside: BoolArray = ((np.abs(local[:, 2]) <= self.half_thickness * (1 + 1e-9))
                             & (s >= 0) & self._kept[np.maximum(s, 0)])
        return inside


Radii = Callable[[FloatArray], FloatArray]


def flat_shape(points: FloatArray, rank: int, alpha: float | None, local_radii: Radii) -> FlatShape:
    """The thickened shape of ``points`` (distinct, ``(n, 3)``, ``n >= 2``) of affine ``rank`` 1 or 2;
    ``alpha``: a radius (m), or None for the local rule with the 3-D shape's ``local_radii``."""
    half = FLAT_HALF_THICKNESS
    centre = points.mean(axis=0)
    _, _, axes = np.linalg.svd(points - centre)
    axes = np.array(axes, dtype=np.float64)
    axes[2] = np.cross(axes[0], axes[1])
    uv = (points - centre) @ axes[:2].T
    if rank == 2:
        planar = _planar_alpha(uv, alpha, local_radii)
        if planar is not None:
            tri, kept, a = planar
            return _prism(tri, kept, centre, axes, half, a, "planar-alpha-shape", None)
        what = "the points lie on a curve in a plane (e.g. one revolute joint): their hull in the plane"
    else:
        what = "the points are collinear (e.g. one prismatic joint): the segment"
    corners = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    grown = (uv[:, None, :] + corners[None]).reshape(-1, 2)  # + a square of side 2 x half: never flat
    uv = grown[ConvexHull(grown).vertices]
    tri = Delaunay(uv)
    return _prism(tri, np.ones(len(tri.simplices), dtype=bool), centre, axes, half, alpha, "flat-hull",
                  f"flat workspace: {what}, grown by {half * 1e3:g} mm in every direction")


def _planar_alpha(uv: FloatArray, alpha: float | None,
                  local_radii: Radii) -> tuple[Delaunay, BoolArray, float] | None:
    """2-D alpha shape in the plane: the triangulation, the kept triangles and the reported radius; None
    when no triangle survives (the points lie on a curve) or Qhull fails."""
    try:
        tri = Delaunay(uv)
    except QhullError:
        return None
    s = np.asarray(tri.simplices, dtype=np.int64)
    a, b, c = uv[s[:, 0]], uv[s[:, 1]], uv[s[:, 2]]
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (b - c, c - a, a - b))
    area2 = np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        radius = la * lb * lc / (2.0 * area2)
    radius[~np.isfinite(radius)] = np.inf
    if alpha is None:
        vertex_radius = local_radii(uv)
        kept = radius <= vertex_radius[s].max(axis=1)
        reported = float(np.median(vertex_radius))
    else:
        reported = alpha
        kept = radius <= reported
    return (tri, kept, reported) if kept.any() else None


def _prism(tri: Delaunay, kept: BoolArray, centre: FloatArray, axes: FloatArray, half: float,
           alpha: float | None, method: str, warning: str | None) -> FlatShape:
    """The kept triangles as a prism: top (+half along axis 2) and bottom faces and a wall along every
    boundary edge, all outward."""
    uv = np.asarray(tri.points, dtype=np.float64)
    t = np.asarray(tri.simplices, dtype=np.int64)[kept].copy()
    e1, e2 = uv[t[:, 1]] - uv[t[:, 0]], uv[t[:, 2]] - uv[t[:, 0]]
    cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    t[cross < 0] = t[cross < 0][:, [0, 2, 1]]  # counter-clockwise: the top face's normal is +axis 2
    n = len(uv)
    flat3 = centre + uv @ axes[:2]
    vertices = np.concatenate([flat3 - half * axes[2], flat3 + half * axes[2]])
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    inner = {(int(i), int(j)) for i, j in directed}
    boundary = np.array([(i, j) for i, j in inner if (j, i) not in inner], dtype=np.int64).reshape(-1, 2)
    i, j = boundary[:, 0], boundary[:, 1]
    walls = np.concatenate([np.c_[i, j, j + n], np.c_[i, j + n, i + n]])
    triangles = np.concatenate([t + n, t[:, ::-1], walls])
    area = float(np.abs(cross).sum() / 2.0)
    return FlatShape(vertices, triangles, area * 2.0 * half, alpha, method, warning, half, centre, axes,
                     tri, kept)
