"""Alpha shape (robwot_sim.workspace.alpha_shape) and the STL/CSV writers on synthetic point clouds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from scipy.spatial import ConvexHull

from robwot_sim.workspace.alpha_shape import AlphaShape, alpha_shape, auto_alpha, thin_interior
from robwot_sim.workspace.io import read_stl, write_csv, write_stl


def shell_points(n: int, r1: float, r2: float, seed: int) -> npt.NDArray[np.float64]:
    """Uniform in (yaw, pitch, r) like the shell robot: dense at the poles and the inner radius."""
    rng = np.random.default_rng(seed)
    yaw, pitch = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi / 2, np.pi / 2, n)
    r = rng.uniform(r1, r2, n)
    return np.c_[r * np.cos(pitch) * np.cos(yaw), r * np.cos(pitch) * np.sin(yaw), r * np.sin(pitch)]


def edge_counts(tris: npt.NDArray[np.float64]) -> tuple[npt.NDArray[np.int64], bool]:
    """Per undirected edge, how many triangles share it (vertices welded by exact coordinates), and
    whether every directed edge appears once (consistent winding)."""
    _, idx = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    t = idx.reshape(-1, 3)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    _, dcounts = np.unique(directed, axis=0, return_counts=True)
    _, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    return counts, bool((dcounts == 1).all())


def signed_volume(tris: npt.NDArray[np.float64]) -> float:
    return float(np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])).sum() / 6.0)


def test_cube_volume_and_classification() -> None:
    """A uniformly filled unit cube: the alpha shape lies within the points' convex hull and loses at
    most 6 % of the volume (alpha carves a thin layer at flat faces); inside/outside are classified
    correctly 2 cm away from the faces."""
    p = np.random.default_rng(1).random((20000, 3))
    s = alpha_shape(p)
    assert s.method == "alpha-shape" and s.warning is None
    assert 0.94 < s.volume <= ConvexHull(p).volume
    q = np.random.default_rng(2).uniform(-0.5, 1.5, (5000, 3))
    inside = (q > 0.02).all(axis=1) & (q < 0.98).all(axis=1)
    outside = (q < -0.02).any(axis=1) | (q > 1.02).any(axis=1)
    c = s.contains(q)
    assert c[inside].all() and not c[outside].any()


def test_shell_surface_closed_outward(tmp_path: Path) -> None:
    """Shell cloud: STL closed (edges shared by exactly 2 faces), consistently wound, outward
    (signed volume positive and equal to the kept tetrahedra's volume); the cavity stays empty."""
    s = alpha_shape(shell_points(20000, 0.1, 0.25, seed=3))
    write_stl(tmp_path / "s.stl", s.vertices, s.triangles)
    tris, normals = read_stl(tmp_path / "s.stl")
    counts, consistent = edge_counts(tris)
    assert len(tris) == len(s.triangles) > 100
    assert (counts == 2).all() and consistent
    assert signed_volume(tris) == pytest.approx(s.volume, rel=1e-4)
    assert s.volume > 0
    centre = tris.mean(axis=1)  # just behind each face is inside, just in front of it is outside
    assert s.contains(centre - 1e-5 * normals).mean() > 0.999
    assert s.contains(centre + 1e-5 * normals).mean() < 0.001
    assert not s.contains(np.zeros((1, 3)))[0]


def test_planar_points_fall_back_to_hull() -> None:
    """Coplanar points (a planar robot) give the convex hull with a warning, not an error."""
    rng = np.random.default_rng(4)
    p = np.c_[rng.uniform(-1, 1, (500, 2)), np.full(500, 0.3)]
    s = alpha_shape(p)
    assert s.method == "convex-hull"
    assert s.warning is not None and "coplanar" in s.warning
    counts, _ = edge_counts(s.vertices[s.triangles])
    assert len(s.triangles) > 0 and (counts == 2).all()
    assert s.volume == pytest.approx(0.0, abs=1e-9)


def test_too_few_points_and_tiny_alpha() -> None:
    """Fewer than 4 points: empty hull with a warning; an alpha smaller than every tetrahedron: hull."""
    s = alpha_shape(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]))
    assert (s.method, len(s.triangles), s.volume) == ("convex-hull", 0, 0.0)
    assert s.warning is not None and "3 distinct points" in s.warning
    p = np.random.default_rng(5).random((300, 3))
    hull = alpha_shape(p, 1e-6)
    assert hull.method == "convex-hull" and hull.warning is not None and "alpha" in hull.warning
    assert hull.alpha == 1e-6
    assert 0.5 < hull.volume <= 1.0
    assert hull.contains(np.array([[0.5, 0.5, 0.5]]))[0]
    assert not hull.contains(np.array([[1.5, 0.5, 0.5]]))[0]


def test_auto_alpha_scales_with_spacing() -> None:
    """The automatic radius shrinks as the cloud gets denser (about n^(-1/3))."""
    rng = np.random.default_rng(6)
    a1, a8 = auto_alpha(rng.random((2000, 3))), auto_alpha(rng.random((16000, 3)))
    assert a8 / a1 == pytest.approx(0.5, rel=0.15)


def test_csv_writer_format(tmp_path: Path) -> None:
    """CSV header, %.6f metres, 1/0 flags and optional joint columns."""
    pos = np.array([[0.1234567, -2.0, 3.5], [0.0, 0.0, 1e-7]])
    write_csv(tmp_path / "w.csv", pos, np.array([True, False]), np.array([[0.5, -0.25], [1, 2]]), ["a", "b"])
    lines = (tmp_path / "w.csv").read_text().splitlines()
    assert lines == ["x,y,z,collision_free,a,b", "0.123457,-2.000000,3.500000,1,0.500000,-0.250000",
                     "0.000000,0.000000,0.000000,0,1.000000,2.000000"]


def test_interior_thinning_keeps_the_surface() -> None:
    """Thinning deep interior points: with 2 layers the surface is identical to no thinning; with the
    default single layer the volume changes by < 0.1 % and the triangulated cloud is much smaller."""
    p = np.random.default_rng(7).random((20000, 3))
    a = auto_alpha(p)
    assert len(thin_interior(p, a, 2)) < 0.9 * len(p)
    assert len(thin_interior(p, a, 1)) < 0.6 * len(p)
    full, exact, default = (alpha_shape(p, a, thin_layers=n) for n in (0, 2, 1))

    def faces(s: AlphaShape) -> set[tuple[float, ...]]:
        return {tuple(sorted(map(tuple, t))) for t in s.vertices[s.triangles].tolist()}

    assert exact.volume == pytest.approx(full.volume, rel=1e-12)
    assert faces(exact) == faces(full)
    assert default.volume == pytest.approx(full.volume, rel=1e-3)
