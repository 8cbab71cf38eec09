"""Segmentation of a scanned cloud: the support planes (floor, table tops), then the objects as clusters.

The cloud is in the world frame (Z up, metres) with the robots' own points already removed.

Supports (:func:`find_supports`) are found by RANSAC restricted to near-horizontal planes. Decisions:

* Hypotheses are scored in one vectorised step: a batch of point triples gives a batch of planes, each
  scored against a random sample of the points; the few best are scored again against every point. Half the
  triples are drawn uniformly, half *locally in height* (three points close in the z-sorted order): a
  horizontal plane packs its points in a thin band of that order, so such triples fall on one plane far more
  often than uniform ones, which is what finds a small table among a large floor and many object sides.
* The winner is refined by total least squares (the smallest principal axis of its inliers, of at most
  ``_FITTED`` of them evenly spread, inliers recomputed, twice). When the inliers' own plane tilts past
  ``max_tilt`` they are a slice of a steeper surface (a band across a ramp or across objects' sides), not a
  support: they leave the search and stay with the objects. The rounds are bounded (a ramp could
  otherwise be sliced band after band).
* Its inliers are split into connected patches on a 2-D occupancy grid in the plane (8-connectivity): two
  tables at the same height are two supports. Every patch of at least ``min_points`` becomes a
  :class:`Plane`, refined on its own points. All the plane's inliers leave the pool before the next search,
  but the points of too-small patches are in no Plane: they stay with the objects (a thin object's top at
  table height is an object, not a support).
* A horizontal face with ``min_points`` points (a large box's top) is a support by this definition; choose
  ``min_points`` above the points of an object's top face, or ``most`` to hold only the expected supports.
* Everything is deterministic for a given ``rng``; the default generator has a fixed seed.

Objects (:func:`clusters`) are Euclidean clusters computed on voxels of side ``gap``: two points closer
than ``gap`` lie in the same or 26-adjacent voxels, so they are never split; points in adjacent voxels may
be up to ``2 * sqrt(3) * gap`` apart and are joined. Clustering therefore only over-merges, which only makes
the covers of :mod:`robwot_sim.scan.shapes` bigger: the conservative direction. Voxels are labelled on a
dense grid by ``scipy.ndimage.label`` while the grid is small, else as a sparse graph of occupied voxels.
"""

from __future__ import annotations

import math
from typing import NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
_Num = TypeVar("_Num", bound=np.generic)

_HYPOTHESES = 256       # plane hypotheses per RANSAC round (half uniform, half local in height)
_SAMPLE = 8192          # points every hypothesis is scored against
_RESCORED = 8           # best hypotheses scored again against every point
_REFINES = 2            # least-squares refinements (fit, recompute inliers)
_FITTED = 16384         # points of a larger patch a plane is fitted on (every k-th)
_ROUNDS_PER_PLANE = 3   # RANSAC rounds at most: this many per plane asked for, plus _ROUNDS_MORE (rounds
_ROUNDS_MORE = 5        # that give no support, such as slices of a ramp or small coplanar tops, count too)
_SEARCHED = 32768        # points of a larger cloud the search runs on (a random sample)
_SAMPLED_SHARE = 0.7    # of a plane's expected share of the sample, what it must hold there to be taken
_GRID_SIDE_MAX = 4096   # most cells along one side of a plane's occupancy grid (its cell grows beyond)
_DENSE_MIN = 1 << 16    # a voxel grid of at most max(_DENSE_MIN, _DENSE_PER_POINT * n) cells is labelled
_DENSE_PER_POINT = 16   # densely (time grows with cells), else as a sparse graph (time grows with points)
_DENSE_MAX = 1 << 24    # never more cells than this (memory of the int32 labels)


class Plane(NamedTuple):
    """A support plane: ``normal . x == offset`` on it; ``inliers`` index the points given to the search."""

    normal: FloatArray      # [3] unit, pointing up (z > 0)
    offset: float
    inliers: IntArray       # in no particular order


def as_points(points: npt.ArrayLike) -> FloatArray:
    """The points as a finite float64 ``[n, 3]`` array (ValueError otherwise)."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must be [n, 3], got shape {pts.shape}")
    if not np.isfinite(pts).all():
        raise ValueError("points must be finite")
    return pts


def extent(pts: npt.NDArray[_Num]) -> tuple[npt.NDArray[_Num], npt.NDArray[_Num]]:
    """The per-axis least and greatest of non-empty ``pts`` [n, d], taken column by column (numpy's axis-0
    reductions over a narrow array are many times slower than over one contiguous column each)."""
    cols = range(pts.shape[1])
    lo: npt.NDArray[_Num] = np.array([pts[:, i].min() for i in cols], dtype=pts.dtype)
    hi: npt.NDArray[_Num] = np.array([pts[:, i].max() for i in cols], dtype=pts.dtype)
    return lo, hi


def within(pts: FloatArray, lo: npt.ArrayLike, hi: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """True for each of ``pts`` [n, d] inside the closed box ``lo``..``hi`` (column by column, as
    :func:`extent`)."""
    lo_, hi_ = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    out = np.ones(len(pts), dtype=bool)
    for i in range(pts.shape[1]):
        col = pts[:, i]
        out &= (col >= lo_[i]) & (col <= hi_[i])
    return out


def _hypotheses(pts: FloatArray, window: int, cos_tilt: float,
                rng: np.random.Generator) -> tuple[FloatArray, FloatArray]:
    """Plane hypotheses (normals ``[h, 3]`` with z > 0, offsets ``[h]``) from triples of ``pts`` (sorted by
    z), only those within the tilt bound; half the triples uniform, half within ``window`` ranks in z."""
    n = len(pts)
    half = _HYPOTHESES // 2
    uniform = rng.integers(0, n, size=(half, 3))
    anchor = rng.integers(0, n, size=half)
    near = np.clip(anchor[:, None] + rng.integers(-window, window + 1, size=(half, 2)), 0, n - 1)
    local = np.column_stack([anchor, near])
    triples = np.vstack([uniform, local])
    p0, p1, p2 = pts[triples[:, 0]], pts[triples[:, 1]], pts[triples[:, 2]]
    normals = np.cross(p1 - p0, p2 - p0)
    length = np.linalg.norm(normals, axis=1)
    ok = length > 1e-12
    normals = normals[ok] / length[ok, None]
    normals *= np.where(normals[:, 2] < 0.0, -1.0, 1.0)[:, None]
    keep = normals[:, 2] >= cos_tilt
    normals = normals[keep]
    return normals, np.einsum("ij,ij->i", normals, p0[ok][keep])


def _ransac(pts: FloatArray, noise: float, window: int, cos_tilt: float,
            rng: np.random.Generator) -> tuple[FloatArray, float, int] | None:
    """The best near-horizontal plane of one vectorised round among ``pts`` (sorted by z): normal, offset,
    inlier count; or None when no triple gave a plane within the tilt bound."""
    normals, offsets = _hypotheses(pts, window, cos_tilt, rng)
    if len(normals) == 0:
        return None
    sample = pts[rng.integers(0, len(pts), size=min(len(pts), _SAMPLE))]
    dist = normals @ sample.T  # [h, s], worked on in place: the scoring's temporaries cost more than it
    dist -= offsets[:, None]
    np.abs(dist, out=dist)
    scores = np.count_nonzero(dist <= noise, axis=1)
    best = np.argsort(-scores, kind="stable")[:_RESCORED]
    full = (np.abs(pts @ normals[best].T - offsets[best]) <= noise).sum(axis=0)
    pick = best[int(np.argmax(full))]
    return normals[pick], float(offsets[pick]), int(full.max())


def _refine(pts: FloatArray, normal: FloatArray, offset: float, noise: float,
            cos_tilt: float) -> tuple[FloatArray, float] | None:
    """Total-least-squares refinement of a plane on its inliers among ``pts`` (recomputed each time), or
    None when the inliers' own plane leaves the tilt bound: they are a slice of a steeper surface (a ramp,
    an object's side), not a support."""
    if len(pts) > _FITTED:  # the plane of a large patch fitted on an even share of its points
        pts = pts[:: len(pts) // _FITTED + 1]
    for _ in range(_REFINES):
        inl = pts[np.abs(pts @ normal - offset) <= noise]
        if len(inl) < 3:
            break
        centre = inl.mean(axis=0)
        d = inl - centre
        _, vecs = np.linalg.eigh(d.T @ d)
        fit = vecs[:, 0] * (1.0 if vecs[2, 0] >= 0.0 else -1.0)
        if fit[2] < cos_tilt:
            return None
        normal, offset = fit, float(fit @ centre)
    return normal, offset


def _plane_basis(normal: FloatArray) -> FloatArray:
    """Two unit vectors ``[3, 2]`` spanning the plane of ``normal`` (orthonormal with it)."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return np.column_stack([u, np.cross(normal, u)])


def _patches(pts: FloatArray, normal: FloatArray, cell: float) -> IntArray:
    """Label (0..k-1) of each point's connected patch on an occupancy grid of ``cell`` in the plane
    (8-connected cells: points up to ``2 * sqrt(2) * cell`` apart in the plane may join, never split
    when closer than ``cell``)."""
    uv = pts @ _plane_basis(normal)
    lo, hi = extent(uv)
    cell = max(cell, float((hi - lo).max()) / (_GRID_SIDE_MAX - 1))
    ij = np.floor((uv - lo) / cell).astype(np.intp)
    grid = np.zeros(tuple(int(v) + 1 for v in extent(ij)[1]), dtype=bool)
    grid[ij[:, 0], ij[:, 1]] = True
    labels, _ = ndimage.label(grid, structure=np.ones((3, 3), dtype=bool))
    return np.asarray(labels[ij[:, 0], ij[:, 1]], dtype=np.intp) - 1


def _supports(pts: FloatArray, inliers: IntArray, normal: FloatArray, offset: float, noise: float,
              cos_tilt: float, cell: float, min_points: int) -> list[Plane]:
    """The connected patches of a plane's inliers holding ``min_points`` points each, each refined on its
    own points (a patch whose own plane is too steep is dropped)."""
    patch = _patches(pts[inliers], normal, cell)
    out = []
    for label in np.flatnonzero(np.bincount(patch) >= min_points):
        members = inliers[patch == label]
        fit = _refine(pts[members], normal, offset, noise, cos_tilt)
        if fit is None:
            continue
        kept = members[np.abs(pts[members] @ fit[0] - fit[1]) <= noise]
        if len(kept) >= min_points:
            out.append(Plane(fit[0], fit[1], kept))
    return out


def find_supports(points: npt.ArrayLike, noise: float, min_points: int = 500, max_tilt: float = 0.17,
                  most: int = 3, rng: np.random.Generator | None = None, *,
                  cell: float = 0.05) -> list[Plane]:
    """The support planes of a cloud, largest first, at most ``most``: near-horizontal (normal within
    ``max_tilt`` rad of +Z) connected patches of at least ``min_points`` points within ``noise`` metres of
    their least-squares plane. ``cell`` is the in-plane grid splitting a plane's inliers into patches: it
    must exceed the spacing of the scan's points on a support, and be below the gap between two supports
    at one height for them to be told apart. ``rng`` makes the search repeatable (default: a fixed seed).

    A large cloud is searched on a random sample of ``_SEARCHED`` points (a plane holding ``min_points`` of
    the cloud holds its share of the sample); a plane found there takes its inliers from every point."""
    pts = as_points(points)
    if noise <= 0.0 or cell <= 0.0:
        raise ValueError("noise and cell must be > 0")
    rng = np.random.default_rng(0) if rng is None else rng
    cos_tilt = math.cos(max_tilt)
    pool = np.arange(len(pts), dtype=np.intp)  # every point not yet a support's
    share = min(1.0, _SEARCHED / max(1, len(pts)))
    sample = pool if share >= 1.0 else rng.choice(len(pts), size=_SEARCHED, replace=False)
    zs = pts[sample[np.argsort(pts[sample, 2])]]  # the searched points sorted by z
    searched = np.arange(len(zs), dtype=np.intp)  # positions in zs still searched
    least = max(3, math.ceil(min_points * share * _SAMPLED_SHARE)) if share < 1.0 else min_points
    window = max(2, least // 2)
    planes: list[Plane] = []
    for _ in range(_ROUNDS_PER_PLANE * most + _ROUNDS_MORE):
        if len(planes) >= most or len(searched) < max(least, 3):
            break
        sub = zs[searched]
        found = _ransac(sub, noise, window, cos_tilt, rng)
        if found is None or found[2] < least:
            break
        refined = _refine(sub, found[0], found[1], noise, cos_tilt)
        normal, offset = refined if refined is not None else (found[0], found[1])
        searched = searched[np.abs(sub @ normal - offset) > noise]  # a rejected slice stays objects
        if refined is None:
            continue
        inside = np.abs(pts[pool] @ normal - offset) <= noise
        inliers, pool = pool[inside], pool[~inside]
        if len(inliers) >= min_points:
            planes += _supports(pts, inliers, normal, offset, noise, cos_tilt, cell, min_points)
    planes.sort(key=lambda p: -len(p.inliers))
    return planes[:most]


def _dense_labels(idx: IntArray, dims: tuple[int, ...]) -> IntArray:
    """Per-point label (0..k-1) of 26-connected occupied voxels, on a dense grid of ``dims``."""
    grid = np.zeros(dims, dtype=bool)
    grid[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    labels, _ = ndimage.label(grid, structure=np.ones((3, 3, 3), dtype=bool))
    return np.asarray(labels[idx[:, 0], idx[:, 1], idx[:, 2]], dtype=np.intp) - 1


def _sparse_labels(idx: IntArray, dims: tuple[int, ...]) -> IntArray:
    """Per-point label (0..k-1) of 26-connected occupied voxels, as a graph of the occupied voxels only.

    Voxels get a linear key (z fastest, coordinates shifted by one inside a grid padded by one on each
    side, so a neighbour's key never wraps into another row); sorted, a voxel's neighbours in column
    ``(x + dx, y + dy)`` at ``z - 1, z, z + 1`` are the (at most three) consecutive keys from where
    ``key + offset(dx, dy, -1)`` would be inserted. Four forward column offsets plus the voxel above give
    each of the 13 forward neighbour relations once."""
    sy, sx = dims[2] + 2, (dims[1] + 2) * (dims[2] + 2)
    keys = (idx[:, 0] + 1) * sx + (idx[:, 1] + 1) * sy + (idx[:, 2] + 1)
    ukeys, inverse = np.unique(keys, return_inverse=True)
    v = len(ukeys)
    src = [np.flatnonzero(np.diff(ukeys) == 1)]
    dst = [src[0] + 1]
    for dx, dy in ((0, 1), (1, -1), (1, 0), (1, 1)):
        base = ukeys + dx * sx + dy * sy - 1
        start = np.searchsorted(ukeys, base)
        for dz in range(3):
            pos = np.minimum(start + dz, v - 1)
            diff = ukeys[pos] - base
            hit = np.flatnonzero((diff >= 0) & (diff <= 2))
            src.append(hit)
            dst.append(pos[hit])
    s, d = np.concatenate(src), np.concatenate(dst)
    graph = coo_matrix((np.ones(len(s), dtype=bool), (s, d)), shape=(v, v))
    _, comp = connected_components(graph, directed=False)
    labels: IntArray = np.asarray(comp, dtype=np.intp)[inverse.reshape(-1)]
    return labels


def clusters(points: npt.ArrayLike, gap: float) -> IntArray:
    """Label (0..k-1) per point of its Euclidean cluster: points closer than ``gap`` metres share a label.

    Computed on voxels of side ``gap`` (see the module docstring): never splits points closer than ``gap``,
    may join points up to ``2 * sqrt(3) * gap`` apart; both directions only merge, never lose, a point."""
    pts = as_points(points)
    if not gap > 0.0:
        raise ValueError("gap must be > 0")
    if len(pts) == 0:
        return np.zeros(0, dtype=np.intp)
    lo, hi = extent(pts)
    if float(((hi - lo) / gap).max()) >= 2.0**20:
        raise ValueError(f"the cloud spans more than 2^20 voxels of gap {gap} along one axis")
    idx = np.floor((pts - lo) / gap).astype(np.intp)
    dims = tuple(int(v) + 1 for v in extent(idx)[1])
    cells = math.prod(dims)
    if cells <= min(_DENSE_MAX, max(_DENSE_MIN, _DENSE_PER_POINT * len(pts))):
        return _dense_labels(idx, dims)
    return _sparse_labels(idx, dims)
