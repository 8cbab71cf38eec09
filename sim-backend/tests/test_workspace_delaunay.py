"""Small Delaunay tetrahedra in slabs (``workspace/delaunay.py``) against one scipy triangulation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from robwot_sim.workspace.alpha_shape import alpha_shape
from robwot_sim.workspace.delaunay import circumspheres, small_tetrahedra
from robwot_sim.workspace.mesh import FACES


def quads(simplices: np.ndarray) -> np.ndarray:
    return np.unique(np.sort(simplices, axis=1), axis=0)


def assert_neighbours_consistent(simplices: np.ndarray, neighbors: np.ndarray) -> None:
    t, f = np.nonzero(neighbors >= 0)
    mine = np.sort(simplices[t[:, None], FACES[f]], axis=1)
    other = simplices[neighbors[t, f]]
    assert all(set(a) <= set(b) for a, b in zip(mine.tolist(), other.tolist(), strict=True))
    back = neighbors[neighbors[t, f]]
    assert (back == t[:, None]).any(axis=1).all()


@pytest.mark.parametrize("slabs", [2, 3, 5])
def test_slabs_give_the_tetrahedra_of_one_triangulation_smaller_than_reach(slabs: int) -> None:
    """Any number of slabs: exactly scipy's Delaunay tetrahedra with circumradius < reach, with their
    neighbours across the seams; a point is located in the same tetrahedron."""
    rng = np.random.default_rng(3)
    p = rng.random((30000, 3)) * [2.0, 1.0, 1.0]
    reach = 0.06
    tri = Delaunay(p)
    s = np.asarray(tri.simplices, dtype=np.int64)
    small = circumspheres(p, s)[1] < reach
    one, many = small_tetrahedra(p, reach, slabs=1), small_tetrahedra(p, reach, slabs=slabs)
    assert len(many.pieces) == slabs
    assert np.array_equal(quads(many.simplices), quads(s[small]))
    assert np.array_equal(quads(one.simplices), quads(s[small]))
    assert_neighbours_consistent(many.simplices, many.neighbors)
    # every face of a small tetrahedron whose scipy neighbour is small has its neighbour here
    assert (many.neighbors >= 0).sum() == (one.neighbors >= 0).sum()
    q = rng.random((5000, 3)) * [2.0, 1.0, 1.0]
    where = tri.find_simplex(q)
    found = many.locate(q)
    assert np.array_equal(found >= 0, (where >= 0) & small[np.maximum(where, 0)])
    hit = found >= 0
    assert np.array_equal(np.sort(many.simplices[found[hit]], axis=1), np.sort(s[where[hit]], axis=1))


def test_co_spherical_lattice_falls_back_or_agrees() -> None:
    """A cubic lattice (every cube's corners co-spherical): the slabs may triangulate a seam
    differently; the result is still a set of tetrahedra filling the same volume with matched faces."""
    g = np.stack(np.meshgrid(*(np.arange(12.0),) * 3, indexing="ij"), axis=-1).reshape(-1, 3) * 0.1
    one, two = small_tetrahedra(g, 0.1, slabs=1), small_tetrahedra(g, 0.1, slabs=2)
    assert two.volume.sum() == pytest.approx(one.volume.sum(), rel=1e-9)
    assert two.volume.sum() == pytest.approx(1.1 ** 3, rel=1e-9)
    assert_neighbours_consistent(two.simplices, two.neighbors)


def test_alpha_shape_in_slabs_is_the_one_of_one_triangulation(monkeypatch: pytest.MonkeyPatch) -> None:
    """The alpha shape does not depend on the number of slabs (here 1 and 3 forced)."""
    from robwot_sim.workspace import delaunay

    rng = np.random.default_rng(5)
    p = rng.normal(size=(60000, 3))
    p = p[np.linalg.norm(p, axis=1) < 2.5]
    shapes = []
    for k in (1, 3):
        monkeypatch.setattr(delaunay, "slab_count", lambda _p, _r, k=k: k)
        shapes.append(alpha_shape(p))
    a, b = shapes
    assert len(a._tets.pieces) == 1 and len(b._tets.pieces) == 3
    assert a.volume == pytest.approx(b.volume, rel=1e-12)
    assert {tuple(sorted(map(tuple, t))) for t in a.vertices[a.triangles].tolist()} == \
        {tuple(sorted(map(tuple, t))) for t in b.vertices[b.triangles].tolist()}
    q = rng.normal(size=(20000, 3))
    assert np.array_equal(a.contains(q), b.contains(q))
