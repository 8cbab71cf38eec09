"""Conservative covers of a scanned object's points, and the shadow it casts from a sensor.

The one guarantee of every cover: each point of the cluster *inflated by* ``noise`` (the ball of radius
``noise`` around it) lies inside the cover. A scanned point is within ``noise`` of the true surface, so the
cover holds the surface the scan saw. Three covers, each safe on its own:

* :func:`box_cover`, an oriented box. Objects stand on supports with Z up, so the box turns in yaw only:
  the minimum-area rectangle of the points' 2-D convex hull has a side on a hull edge (rotating calipers:
  every edge direction is tried at once, the objective being the *grown* area), z spans the points, and
  every side is grown by ``noise``.
* :func:`hull_cover`, a convex polyhedron. Two safe constructions are made and the smaller kept: the
  hull's facet planes each moved out by ``noise`` (intersected again: exact for the ball, but a sharp
  vertex moves out by more than ``noise``), and the hull of every hull vertex plus the 8 corners of the
  cube of half-side ``noise`` (the cube holds the ball; never spiky, up to ``sqrt(3) * noise`` out).
  Each result is checked against every point before it is returned; degenerate clusters (fewer than 4
  points, collinear, coplanar) take the cube construction, the cube giving the thickness (at least
  ``_MIN_THICKNESS`` even when ``noise`` is 0).
* :func:`voxel_cover`, axis-aligned boxes. Every voxel of side ``side`` (aligned on the world origin, so
  neighbouring clusters share a lattice) that the cube of half-side ``noise`` around a point touches is
  marked; with ``fill`` (the default) each column of marked voxels is filled down to the cluster's lowest
  voxel layer, as an object standing on a support is solid below what the sensor saw of it (this also makes
  its volume comparable to the box's and the hull's, which are solid). Voxels are merged into boxes along
  x runs, then along y and z where whole runs line up; the boxes are disjoint.

:func:`tightest` picks the cover of least volume, except that a simpler cover (box, then hull, then
voxels) within ``slack`` of the least is preferred: a box is one primitive for the collision checker, and
the hull of a box's sampled surface cuts the box's edges and corners where the samples miss them, so it
comes out a little smaller than the box without being a better description of the object.

Obstacles are scene-file dicts (``examples/scenes/table.json``): ``{"shape": {"type": "box", "size":
[sx, sy, sz]}, "position": [x, y, z], "orientation": [qx, qy, qz, qw]}`` with full extents in metres, and
no ``"name"`` (the caller names them).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

from robwot_sim.scan.segment import FloatArray, IntArray, Plane, as_points, extent

Mesh = tuple[FloatArray, IntArray]
Cover = dict[str, Any] | Mesh | list[dict[str, Any]]

_MIN_THICKNESS = 1e-6   # m: a degenerate cluster's hull is at least this far out when noise is 0
_HOLD_TOL = 1e-10       # m: rounding a returned hull may show against a point's inflated distance
_FEW = 64              # points up to which a hull is asked of qhull at once
#: directions whose extreme points span the polytope ``hull_candidates`` filters with: 8 in the plane, 14
#: in space (the axes and the cube's diagonals)
_DIRECTIONS = {2: [d for d in itertools.product((-1, 0, 1), repeat=2) if any(d)],
               3: [d for d in itertools.product((-1, 0, 1), repeat=3) if sum(map(abs, d)) in (1, 3)]}
_CUBE = np.array(list(itertools.product((-1.0, 1.0), repeat=3)))
_IDENTITY = [0.0, 0.0, 0.0, 1.0]


def _cluster(points: npt.ArrayLike, noise: float) -> FloatArray:
    """A non-empty cluster's points as ``[n, 3]`` floats, ``noise`` checked (ValueError otherwise)."""
    pts = as_points(points)
    if len(pts) == 0:
        raise ValueError("a cover needs at least one point")
    if not (math.isfinite(noise) and noise >= 0.0):
        raise ValueError("noise must be finite and >= 0")
    return pts


def hull_candidates(pts: FloatArray, *, boundary: bool = True) -> FloatArray:
    """The points of ``pts`` [n, 2 or 3] that may be vertices of their convex hull (Akl-Toussaint): those
    not inside the hull of their extreme points along a fixed set of directions, a polytope inside the
    points' hull, and those extreme points. With ``boundary`` a point on the polytope's boundary (within
    rounding) is kept and qhull on what is kept gives exactly the points' hull; without, such points go
    too (many coplanar points, as a shadow's ends on a floor) and the hull is the points' to within 1e-9 of
    their extent, enough for a volume. A set too small or too flat to filter is returned whole."""
    if len(pts) <= _FEW:
        return pts
    cols = [np.ascontiguousarray(pts[:, i]) for i in range(pts.shape[1])]
    dirs = _DIRECTIONS[pts.shape[1]]
    picks = np.unique([int(np.argmax(sum(c * float(w) for c, w in zip(cols, d, strict=True) if w)))
                       for d in dirs])
    try:
        facets = ConvexHull(pts[picks]).equations
    except (QhullError, ValueError):
        return pts
    tol = 1e-9 * (float(np.abs(pts[picks]).max()) + 1e-300) * (-1.0 if boundary else 1.0)
    keep = np.zeros(len(pts), dtype=bool)
    keep[picks] = True
    for f in facets:  # outward normal . x + offset beyond tol: not inside this facet
        keep |= sum(c * float(w) for c, w in zip(cols, f[:-1], strict=True)) + float(f[-1]) > tol
    kept: FloatArray = pts[keep]
    return kept


def _ring(xy: FloatArray) -> FloatArray:
    """The 2-D hull vertices of ``xy`` in order; for a degenerate set (one point, a segment) its distinct
    points, which give the same extents in every direction."""
    try:
        few = hull_candidates(xy)
        ring: FloatArray = few[ConvexHull(few).vertices]
    except (QhullError, ValueError):
        ring = np.unique(xy, axis=0)
    return ring


def _yaw(ring: FloatArray, grow: float) -> float:
    """The yaw (rad) of the minimum-area rectangle holding ``ring`` with each side grown by ``grow``: a
    hull edge's direction (every edge tried at once) or 0 when there is no edge."""
    edges = np.roll(ring, -1, axis=0) - ring
    keep = np.hypot(edges[:, 0], edges[:, 1]) > 0.0
    angles = np.concatenate([[0.0], np.mod(np.arctan2(edges[keep, 1], edges[keep, 0]), math.pi / 2)])
    u = np.column_stack([np.cos(angles), np.sin(angles)])
    v = np.column_stack([-u[:, 1], u[:, 0]])
    width = np.ptp(ring @ u.T, axis=0) + 2.0 * grow
    length = np.ptp(ring @ v.T, axis=0) + 2.0 * grow
    return float(angles[int(np.argmin(width * length))])


def box_cover(points: npt.ArrayLike, noise: float) -> dict[str, Any]:
    """The yaw-only oriented box holding every point grown by ``noise``: a scene obstacle dict."""
    pts = _cluster(points, noise)
    yaw = _yaw(_ring(pts[:, :2]), noise)
    c, s = math.cos(yaw), math.sin(yaw)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    local = pts @ rot                       # the points in the box frame (rot^T p)
    lo, hi = extent(local)
    centre = rot @ ((lo + hi) / 2.0)
    size = hi - lo + 2.0 * noise
    return {"shape": {"type": "box", "size": [float(v) for v in size]},
            "position": [float(v) for v in centre],
            "orientation": [0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0)]}


def _mesh(vertices: FloatArray) -> tuple[Mesh, FloatArray]:
    """The convex hull of ``vertices`` as a mesh (its vertices only, triangles wound outward) and its facet
    equations ``[f, 4]`` (``n . x + d <= 0`` inside)."""
    hull = ConvexHull(vertices)
    remap = np.full(len(vertices), -1, dtype=np.intp)
    remap[hull.vertices] = np.arange(len(hull.vertices))
    tri = remap[hull.simplices]
    out = vertices[hull.vertices]
    a, b, c = out[tri[:, 0]], out[tri[:, 1]], out[tri[:, 2]]
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0.0
    tri[inward] = tri[inward][:, [0, 2, 1]]
    return (out, tri), np.asarray(hull.equations, dtype=np.float64)


def _holds(equations: FloatArray, pts: FloatArray, noise: float) -> bool:
    """Whether every point is at least ``noise`` inside every facet (up to ``_HOLD_TOL`` of rounding). Asked
    of the vertices of the points' hull: a convex cover holding the ball around each of them holds the ball
    around every point of their hull."""
    return bool((pts @ equations[:, :3].T + equations[:, 3] <= -noise + _HOLD_TOL).all())


def _offset_hull(hull: ConvexHull, noise: float) -> FloatArray | None:
    """The vertices of the hull's facet planes each moved out by ``noise`` (None if qhull fails)."""
    _, first = np.unique(np.round(hull.equations, 12), axis=0, return_index=True)  # coplanar triangles
    planes = np.array(hull.equations[np.sort(first)], dtype=np.float64)
    planes[:, 3] -= noise
    inside = hull.points[hull.vertices].mean(axis=0)
    try:
        return np.asarray(HalfspaceIntersection(planes, inside).intersections, dtype=np.float64)
    except (QhullError, ValueError):
        return None


def _mesh_volume(mesh: Mesh) -> float:
    """Volume of a closed mesh wound outward (sum of signed tetrahedra from the origin)."""
    v, t = mesh
    return float(np.einsum("ij,ij->i", v[t[:, 0]], np.cross(v[t[:, 1]], v[t[:, 2]])).sum() / 6.0)


def hull_cover(points: npt.ArrayLike, noise: float) -> Mesh:
    """A convex polyhedron (vertices ``[m, 3]``, triangles ``[t, 3]`` wound outward) holding every point
    grown by ``noise``; never degenerate (see the module docstring)."""
    pts = _cluster(points, noise)
    candidates: list[Mesh] = []
    try:
        hull = ConvexHull(hull_candidates(pts))
        base = hull.points[hull.vertices]
    except (QhullError, ValueError):
        hull, base = None, np.unique(pts, axis=0)
    if hull is not None:
        moved = _offset_hull(hull, noise)
        if moved is not None:
            try:
                mesh, equations = _mesh(moved)
                if _holds(equations, base, noise):
                    candidates.append(mesh)
            except (QhullError, ValueError):
                pass
    r = max(noise, _MIN_THICKNESS) + _HOLD_TOL  # the margin absorbs qhull's rounding
    mesh, equations = _mesh((base[:, None, :] + r * _CUBE[None, :, :]).reshape(-1, 3))
    if not _holds(equations, base, noise):
        raise ArithmeticError("the cube-inflated hull does not hold its points")  # qhull rounding
    candidates.append(mesh)
    return min(candidates, key=_mesh_volume)


def _merge(lo: IntArray, hi: IntArray, axis: int) -> tuple[IntArray, IntArray]:
    """Boxes (inclusive voxel bounds) merged along ``axis`` where they agree on the other axes' bounds and
    touch end to start; disjoint boxes stay disjoint."""
    others = [a for a in range(3) if a != axis]
    key = np.column_stack([lo[:, others], hi[:, others]])
    order = np.lexsort((lo[:, axis], *key.T[::-1]))
    lo, hi, key = lo[order], hi[order], key[order]
    joins = (key[1:] == key[:-1]).all(axis=1) & (lo[1:, axis] == hi[:-1, axis] + 1)
    starts = np.flatnonzero(np.concatenate([[True], ~joins]))
    ends = np.concatenate([starts[1:] - 1, [len(lo) - 1]])
    new_lo, new_hi = lo[starts], hi[starts].copy()
    new_hi[:, axis] = hi[ends, axis]
    return new_lo, new_hi


def _unique_rows(rows: npt.NDArray[np.int64]) -> tuple[npt.NDArray[np.int64], IntArray]:
    """The distinct rows of an integer ``[n, d]`` array in lexicographic order and, per row, the index of
    its distinct row: ``np.unique(rows, axis=0, return_inverse=True)``, sorted as one integer key per row
    (numpy's row-wise unique sorts a structured view, many times slower)."""
    lo, hi = extent(rows)
    dims = hi - lo + 1
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:
        u, inv = np.unique(rows, axis=0, return_inverse=True)
        return u, inv.reshape(-1)
    key = np.zeros(len(rows), dtype=np.int64)
    for i in range(rows.shape[1]):
        key = key * dims[i] + (rows[:, i] - lo[i])
    keys, inverse = np.unique(key, return_inverse=True)
    out = np.empty((len(keys), rows.shape[1]), dtype=np.int64)
    for i in reversed(range(rows.shape[1])):
        keys, out[:, i] = np.divmod(keys, dims[i])
        out[:, i] += lo[i]
    return out, inverse.reshape(-1)


def _voxels(pts: FloatArray, noise: float, side: float) -> IntArray:
    """The distinct voxels ``[v, 3]`` (index ``floor(x / side)``) touched by each point's cube of
    half-side ``noise``, bounds widened by a rounding margin so a face at a voxel boundary is never lost."""
    margin = 1e-12 * (1.0 + float(np.abs(pts).max()))
    first = np.floor((pts - noise - margin) / side).astype(np.int64)
    last = np.floor((pts + noise + margin) / side).astype(np.int64)
    span = int((last - first).max())
    parts = []
    for step in itertools.product(range(span + 1), repeat=3):
        cand = first + np.array(step, dtype=np.int64)
        parts.append(cand[(cand <= last).all(axis=1)])
    return _unique_rows(np.concatenate(parts))[0]


def voxel_cover(points: npt.ArrayLike, noise: float, side: float, *,
                fill: bool = True) -> list[dict[str, Any]]:
    """Axis-aligned boxes (scene obstacle dicts) of the voxels of ``side`` touched by every point grown by
    ``noise``, each column filled down to the lowest voxel layer with ``fill``; merged to few boxes."""
    pts = _cluster(points, noise)
    if not (math.isfinite(side) and side > 0.0):
        raise ValueError("side must be finite and > 0")
    vox = _voxels(pts, noise, side)
    if fill:
        cols, inverse = _unique_rows(vox[:, :2])
        top = np.full(len(cols), np.iinfo(np.int64).min, dtype=np.int64)
        np.maximum.at(top, inverse.reshape(-1), vox[:, 2])
        bottom = np.full(len(cols), int(vox[:, 2].min()), dtype=np.int64)
        lo, hi = np.column_stack([cols, bottom]), np.column_stack([cols, top])
    else:
        lo, hi = vox, vox.copy()
    for axis in range(3):
        lo, hi = _merge(lo, hi, axis)
    size = (hi - lo + 1) * side
    centre = (lo + hi + 1) * (side / 2.0)
    return [{"shape": {"type": "box", "size": [float(v) for v in sz]}, "position": [float(v) for v in c],
             "orientation": list(_IDENTITY)} for sz, c in zip(size, centre, strict=True)]


def volume_of(cover: Cover) -> float:
    """Volume (m^3) of a box obstacle dict, a hull mesh ``(vertices, triangles)`` or a list of boxes."""
    if isinstance(cover, dict):
        return float(np.prod(cover["shape"]["size"]))
    if isinstance(cover, list):
        return float(sum(np.prod(box["shape"]["size"]) for box in cover))
    return _mesh_volume(cover)


def tightest(points: npt.ArrayLike, noise: float, side: float, *, slack: float = 0.1,
             hull: bool = True) -> tuple[str, Cover]:
    """``("box" | "hull" | "voxels", cover)``: the cover of least volume, except that the first of box, hull,
    voxels within ``slack`` (a fraction) of the least is taken (``slack=0``: strictly the least); without
    ``hull``, the hull is not among them (it could not be written)."""
    pts = _cluster(points, noise)
    covers: list[tuple[str, Cover]] = [("box", box_cover(pts, noise)),
                                       *([("hull", hull_cover(pts, noise))] if hull else []),
                                       ("voxels", voxel_cover(pts, noise, side))]
    volumes = [volume_of(cover) for _, cover in covers]
    least = min(volumes)
    return next(c for c, v in zip(covers, volumes, strict=True) if v <= least * (1.0 + slack))


def shadow(points: npt.ArrayLike, sensor: npt.ArrayLike, floor: Plane | None, reach: float) -> FloatArray:
    """Points whose convex hull is the shadow of ``points`` seen from ``sensor`` (world position ``[3]``):
    the points themselves and each pushed away from the sensor along its ray to where the ray meets the
    ``floor`` plane from above, or to ``reach`` metres from the sensor when it never does (the ray goes up,
    or the plane is behind the sensor), never beyond ``reach`` and never nearer than the point (a point at
    or below the floor, within the noise, ends its own ray).

    Conservative only as a convex over-approximation of the union of those rays: it holds every ray
    segment from a given point to its end (both ends are in the set), and more between them; a ray
    through the object between sampled points is held where it ends on the floor (a central projection
    keeps convex combinations), not always where it is cut off at ``reach`` (a sphere bulges out of the
    hull of points on it)."""
    pts = as_points(points)
    eye = np.asarray(sensor, dtype=np.float64).reshape(3)
    if not (np.isfinite(eye).all() and math.isfinite(reach) and reach > 0.0):
        raise ValueError("sensor must be a finite [3] position and reach finite and > 0")
    ray = pts - eye
    dist = np.linalg.norm(ray, axis=1)
    seen = dist > 0.0
    unit = np.zeros_like(ray)
    unit[seen] = ray[seen] / dist[seen, None]
    end = np.full(len(pts), reach)
    if floor is not None:
        towards = unit @ floor.normal
        gap = floor.offset - float(floor.normal @ eye)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = gap / towards
        hits = (towards < 0.0) & (t > 0.0)      # going down onto the plane from above it
        end[hits] = np.minimum(t[hits], reach)
    end = np.maximum(end, dist)
    return np.vstack([pts, eye + unit * end[:, None]])
