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

_FACE = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]], dtype=np.int64)
_EDGE = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)
_MAX_REPAIR_ROUNDS = 50


def boundary_mask(neighbors: IntArray, kept: BoolArray) -> BoolArray:
    """``(m, 4)``: face ``i`` of tetrahedron ``s`` is kept and its neighbour across it is not."""
    across = np.where(neighbors >= 0, kept[np.maximum(neighbors, 0)], False)
    return kept[:, None] & ~across


def boundary_faces(points: FloatArray, simplices: IntArray, neighbors: IntArray, kept: BoolArray) -> IntArray:
    """Triangles ``(f, 3)`` of the kept set's boundary, counter-clockwise seen from outside."""
    mask = boundary_mask(neighbors, kept)
    s, i = np.nonzero(mask)
    tri = simplices[s[:, None], _FACE[i]]
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


def nonmanifold_edges(simplices: IntArray, neighbors: IntArray, kept: BoolArray, n: int) -> IntArray:
    """Keys of boundary edges shared by more than two boundary faces."""
    s, i = np.nonzero(boundary_mask(neighbors, kept))
    keys = _edge_keys(simplices[s[:, None], _FACE[i]], n)
    uniq, counts = np.unique(keys, return_counts=True)
    return uniq[counts > 2]


def fill_nonmanifold_edges(simplices: IntArray, neighbors: IntArray, kept: BoolArray) -> BoolArray:
    """Keep every tetrahedron around each non-manifold boundary edge, until there is none left.

    Returns the new mask (the input is not modified). Filling only adds volume around edges where
    the kept set touched itself, so the surface becomes a closed 2-manifold along its edges.
    """
    n = int(simplices.max()) + 1
    out = kept.copy()
    tet_keys: IntArray | None = None
    for _ in range(_MAX_REPAIR_ROUNDS):
        bad = nonmanifold_edges(simplices, neighbors, out, n)
        if bad.size == 0:
            return out
        if tet_keys is None:
            e = np.sort(simplices[:, _EDGE], axis=2)
            tet_keys = (e[:, :, 0] * n + e[:, :, 1])
        hit = np.isin(tet_keys, bad).any(axis=1)
        out |= hit
    return out
