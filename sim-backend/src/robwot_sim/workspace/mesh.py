"""Surface extraction from a set of kept tetrahedra of a tetrahedralisation (vectorised numpy).

``simplices`` ``(m, 4)`` and ``neighbors`` ``(m, 4)`` follow scipy's ``Delaunay`` convention: face ``i``
of a tetrahedron is the one opposite its vertex ``i`` and ``neighbors[s, i]`` is the tetrahedron across
it (-1 on the convex hull).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

FACES = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]], dtype=np.int64)
_EDGE = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)
_MAX_REPAIR_ROUNDS = 50


def boundary_mask(neighbors: IntArray, kept: BoolArray, own: BoolArray | None = None) -> BoolArray:
    """``(m, 4)``: face ``i`` of tetrahedron ``s`` is kept and its neighbour across it is not (``own``:
    whether the rows of ``neighbors`` are kept, when they are a subset; ``kept`` is over all)."""
    across = np.where(neighbors >= 0, kept[np.maximum(neighbors, 0)], False)
    out: BoolArray = (kept if own is None else own)[:, None] & ~across
    return out


def boundary_faces(points: FloatArray, simplices: IntArray, neighbors: IntArray, kept: BoolArray) -> IntArray:
    """Triangles ``(f, 3)`` of the kept set's boundary, counter-clockwise seen from outside."""
    mask = boundary_mask(neighbors, kept)
    s, i = np.nonzero(mask)
    tri = simplices[s[:, None], FACES[i]]
    opposite = simplices[s, i]
    a, b, c = points[tri[:, 0]], points[tri[:, 1]], points[tri[:, 2]]
    normal = np.cross(b - a, c - a)
    inward = np.einsum("ij,ij->i", normal, points[opposite] - a) > 0
    tri[inward] = tri[inward][:, [0, 2, 1]]
    return tri


def _edge_keys(tri: IntArray, n: int) -> IntArray:
    """Undirected edge keys ``lo * n + hi`` of each triangle's three edges, flattened."""
    e = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    e.sort(axis=1)
    keys: IntArray = e[:, 0] * n + e[:, 1]
    return keys


def nonmanifold_edges(simplices: IntArray, neighbors: IntArray, kept: BoolArray, n: int,
                      rows: IntArray | None = None) -> IntArray:
    """Keys of boundary edges shared by more than two boundary faces (among the faces of ``rows``, all
    tetrahedra by default)."""
    if rows is None:
        mask, tets = boundary_mask(neighbors, kept), simplices
    else:
        mask, tets = boundary_mask(neighbors[rows], kept, kept[rows]), simplices[rows]
    s, i = np.nonzero(mask)
    keys = _edge_keys(tets[s[:, None], FACES[i]], n)
    uniq, counts = np.unique(keys, return_counts=True)
    return uniq[counts > 2]


def fill_nonmanifold_edges(simplices: IntArray, neighbors: IntArray, kept: BoolArray) -> BoolArray:
    """Keep every tetrahedron around each non-manifold boundary edge, until there is none left.

    Returns the new mask (the input is not modified). Filling only adds volume around edges where
    the kept set touched itself, so the surface becomes a closed 2-manifold along its edges.

    Only tetrahedra near the repair are looked at: those around a bad edge share a vertex with it, and
    after a round only edges of the tetrahedra just added can change their count of boundary faces, all
    of those faces belonging to tetrahedra that share a vertex with one just added (10^6 kuka points:
    15 rounds; 4.0 s when every round went over all tetrahedra, 0.5 s).
    """
    n = int(simplices.max()) + 1
    out = kept.copy()
    rows: IntArray | None = None
    for _ in range(_MAX_REPAIR_ROUNDS):
        bad = nonmanifold_edges(simplices, neighbors, out, n, rows)
        if bad.size == 0:
            return out
        around = _touching(simplices, n, np.concatenate([bad // n, bad % n]))
        e = np.sort(simplices[around][:, _EDGE], axis=2)
        hit = around[np.isin(e[:, :, 0] * n + e[:, :, 1], bad).any(axis=1) & ~out[around]]
        out[hit] = True
        rows = _touching(simplices, n, simplices[hit].ravel())
    return out


def _touching(simplices: IntArray, n: int, vertices: IntArray) -> IntArray:
    """Indices of the tetrahedra with a vertex among ``vertices``."""
    near = np.zeros(n, dtype=bool)
    near[vertices] = True
    flags = np.ascontiguousarray(near[simplices])  # (m, 4) bytes: one 32-bit word per tetrahedron
    rows: IntArray = np.flatnonzero(flags.view(np.uint32).ravel())
    return rows
