"""The Delaunay tetrahedra of a 3-D point set whose circumradius is below a bound (``reach``), computed
in slabs side by side: one thread per core (Qhull releases the GIL, so the slabs triangulate at once).

Why the slabs give the same tetrahedra as one triangulation of all points: the slabs cut the x axis at
``b_0 < b_1 < ...`` and slab ``i`` holds the points with ``b_i - reach <= x <= b_{i+1} + reach``. A
tetrahedron of the whole set with circumradius ``r < reach`` and circumcentre ``x`` in ``[b_i, b_{i+1})``
has its circumsphere inside that slab, so its vertices are points of the slab and its sphere is empty of
them: it is a Delaunay tetrahedron of the slab. Conversely such a tetrahedron of the slab has a sphere
empty of every point (those outside the slab are outside the sphere). Each is taken from the one slab
holding its circumcentre. For points in general position (a unique Delaunay tetrahedralisation) the
result does not depend on the number of slabs; with co-spherical points the slabs may triangulate a
seam differently, which the face matching detects (a face left open that a slab says has a small
neighbour, or shared by three tetrahedra), and one triangulation of all points is used instead.

Tetrahedra with ``r >= reach`` are left out on every path, one slab included, so callers (the alpha
shape) must not need them: an alpha shape keeps only tetrahedra smaller than its largest radius.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import Delaunay, QhullError

from robwot_sim.workspace.mesh import FACES

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

# Fewer points than this per slab, or slabs narrower than this many reaches, are not worth a thread.
SLAB_MIN_POINTS = 40_000
SLAB_MIN_WIDTH = 3.0
_KEY_LIMIT = 1 << 21  # face keys a * n^2 + b * n + c fit in 63 bits


@dataclass(frozen=True)
class Piece:
    """One slab's triangulation and, per its tetrahedron, the index among the kept ones minus ``offset``
    (-1: not taken from this slab)."""

    tri: Delaunay
    index: IntArray
    offset: int


@dataclass(frozen=True)
class Tetrahedra:
    """``simplices`` ``(m, 4)`` into the points, ``neighbors`` ``(m, 4)`` (scipy's convention: across the
    face opposite vertex ``i``; -1 when that neighbour is not one of these), circumradius and volume."""

    simplices: IntArray
    neighbors: IntArray
    radius: FloatArray
    volume: FloatArray
    pieces: tuple[Piece, ...]

    def locate(self, points: FloatArray) -> IntArray:
        """Index of the tetrahedron holding each point, -1 when none of these does."""
        out = np.full(len(points), -1, dtype=np.int64)
        for piece in self.pieces:
            if getattr(piece.tri, "_transform", None) is None:
                _set_barycentric_transforms(piece.tri)
            s = np.asarray(piece.tri.find_simplex(points), dtype=np.int64)
            found = np.where(s >= 0, piece.index[np.maximum(s, 0)], -1)
            found = np.where(found >= 0, found + piece.offset, -1)
            out = np.where(out >= 0, out, found)
        return out


@dataclass(frozen=True)
class _Slab:
    """One slab's triangulation, its index of the tetrahedra taken from it, and those tetrahedra."""

    tri: Delaunay
    index: IntArray  # per tetrahedron of tri: index among the taken ones, -1 when not taken
    simplices: IntArray  # into all points
    radius: FloatArray
    volume: FloatArray
    across: IntArray  # neighbours among the taken ones, -1 when not taken from this slab
    required: BoolArray  # faces whose neighbour was taken from another slab


class _Inconsistent(Exception):
    """The slabs disagree at a seam (co-spherical points)."""


def circumspheres(points: FloatArray, simplices: IntArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Circumcentre ``(m, 3)``, circumradius (m, ``inf`` when flat) and volume (m^3) of each tetrahedron."""
    a = points[simplices[:, 0]]
    u, v, w = (points[simplices[:, i]] - a for i in (1, 2, 3))
    vw, wu, uv = np.cross(v, w), np.cross(w, u), np.cross(u, v)
    det = np.einsum("ij,ij->i", u, vw)
    num = (np.einsum("ij,ij->i", u, u)[:, None] * vw + np.einsum("ij,ij->i", v, v)[:, None] * wu
           + np.einsum("ij,ij->i", w, w)[:, None] * uv)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.linalg.norm(num, axis=1) / np.abs(2.0 * det)
        centre = a + num / (2.0 * det)[:, None]
    flat = ~np.isfinite(r)
    r[flat] = np.inf
    centre[flat] = np.nan
    return centre, r, np.abs(det) / 6.0


def slab_count(points: FloatArray, reach: float) -> int:
    """Slabs worth triangulating side by side: one per core, each with at least ``SLAB_MIN_POINTS``
    points and ``SLAB_MIN_WIDTH`` reaches wide (their margins would be most of them otherwise)."""
    if len(points) == 0 or len(points) >= _KEY_LIMIT or not np.isfinite(reach) or reach <= 0:
        return 1
    width = float(np.ptp(points[:, 0]))
    wide = int(width / (SLAB_MIN_WIDTH * reach))
    return max(1, min(os.cpu_count() or 1, len(points) // SLAB_MIN_POINTS, wide))


def small_tetrahedra(points: FloatArray, reach: float, slabs: int | None = None) -> Tetrahedra:
    """The Delaunay tetrahedra of ``points`` with circumradius ``< reach`` (module docstring), in
    ``slabs`` slabs (default ``slab_count``). One triangulation of all points that fails Qhull's
    precision checks is retried with joggled input (``QJ``); ``QhullError`` when that fails too."""
    k = slab_count(points, reach) if slabs is None else max(1, min(int(slabs), len(points)))
    if k > 1 and len(points) < _KEY_LIMIT:
        try:
            return _in_slabs(points, reach, k)
        except (_Inconsistent, QhullError):
            pass
    return _in_slabs(points, reach, 1)


def _in_slabs(points: FloatArray, reach: float, k: int) -> Tetrahedra:
    x = points[:, 0]
    cuts = np.quantile(x, np.arange(1, k) / k) if k > 1 else np.zeros(0)
    bounds = np.concatenate([[-np.inf], cuts, [np.inf]])
    members = [np.arange(len(points))] if k == 1 else [
        np.flatnonzero((x >= bounds[i] - reach) & (x <= bounds[i + 1] + reach)) for i in range(k)]

    def triangulate(i: int) -> _Slab:
        p = points[members[i]]
        try:
            tri = Delaunay(p)
        except QhullError:
            if k > 1:
                raise
            tri = Delaunay(p, qhull_options="QJ")  # a precision failure: joggled input
        local = np.asarray(tri.simplices, dtype=np.int64)
        centre, r, vol = circumspheres(p, local)
        cx = centre[:, 0]
        with np.errstate(invalid="ignore"):
            # small, and its sphere inside the slab: one of the whole set's tetrahedra
            whole = (r < reach) & (cx - r >= bounds[i] - reach) & (cx + r <= bounds[i + 1] + reach)
            take = whole & (cx >= bounds[i]) & (cx < bounds[i + 1])
        index = np.where(take, np.cumsum(take) - 1, -1)  # among the tetrahedra taken from this slab
        nb = np.asarray(tri.neighbors, dtype=np.int64)[take]
        across = np.where(nb >= 0, index[np.maximum(nb, 0)], -1)
        # a neighbour that is one of the whole set's but taken from another slab: must be found there
        required = (nb >= 0) & whole[np.maximum(nb, 0)] & (across < 0)
        return _Slab(tri, index, members[i][local[take]], r[take], vol[take], across, required)

    if k == 1:
        slabs = [triangulate(0)]
    else:
        with ThreadPoolExecutor(max_workers=k) as pool:
            slabs = list(pool.map(triangulate, range(k)))
    offsets = np.cumsum([0] + [len(sl.simplices) for sl in slabs[:-1]])
    pairs = list(zip(slabs, offsets, strict=True))
    tets = Tetrahedra(np.concatenate([sl.simplices for sl, _ in pairs]),
                      np.concatenate([np.where(sl.across >= 0, sl.across + off, -1) for sl, off in pairs]),
                      np.concatenate([sl.radius for sl, _ in pairs]),
                      np.concatenate([sl.volume for sl, _ in pairs]),
                      tuple(Piece(sl.tri, sl.index, int(off)) for sl, off in pairs))
    if k > 1:
        _match_seams(tets, len(points), np.concatenate([sl.required for sl in slabs]))
    return tets


def _match_seams(tets: Tetrahedra, n: int, required: BoolArray) -> None:
    """Fill in the neighbours across slab seams (in place) by matching open faces' vertex triples."""
    t, f = np.nonzero(tets.neighbors < 0)
    tri = np.sort(tets.simplices[t[:, None], FACES[f]], axis=1)
    keys = (tri[:, 0] * n + tri[:, 1]) * n + tri[:, 2]
    order = np.argsort(keys, kind="stable")
    keys, t, f = keys[order], t[order], f[order]
    same = keys[1:] == keys[:-1]
    if (same[1:] & same[:-1]).any():
        raise _Inconsistent("a face shared by three tetrahedra")
    a = np.flatnonzero(same)
    tets.neighbors[t[a], f[a]] = t[a + 1]
    tets.neighbors[t[a + 1], f[a + 1]] = t[a]
    if (required & (tets.neighbors < 0)).any():
        raise _Inconsistent("a seam face without its neighbour")


def _set_barycentric_transforms(tri: Delaunay) -> None:
    """Give ``tri`` its barycentric transforms, vectorised: scipy computes them one simplex at a time
    on the first ``find_simplex`` (seconds for a large triangulation). Same layout as ``tri.transform``;
    NaN for flat tetrahedra, as scipy does."""
    if not hasattr(tri, "_transform"):
        return
    v = np.asarray(tri.points, dtype=np.float64)[np.asarray(tri.simplices)]
    t = np.transpose(v[:, :3] - v[:, 3:4], (0, 2, 1))
    det = np.linalg.det(t)
    scale = np.abs(t).max(axis=(1, 2)) ** 3
    flat = ~(np.abs(det) > 1e-12 * scale)
    t[flat] = np.eye(3)
    inv = np.linalg.inv(t)
    inv[flat] = np.nan
    tri._transform = np.ascontiguousarray(np.concatenate([inv, v[:, 3:4]], axis=1))
