"""Alpha shape (robwot_sim.workspace.alpha_shape) and the STL/CSV writers on synthetic point clouds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest
from scipy.spatial import ConvexHull

from robwot_sim.workspace.alpha_shape import AlphaShape, alpha_shape, auto_alpha, thin_interior
from robwot_sim.workspace.flat_shape import FlatShape
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
    correctly one sample spacing (20000^(-1/3) = 3.7 cm) inside and 2 cm outside the faces."""
    p = np.random.default_rng(1).random((20000, 3))
    s = alpha_shape(p)
    assert s.method == "alpha-shape" and s.warning is None
    assert 0.94 < s.volume <= ConvexHull(p).volume
    q = np.random.default_rng(2).uniform(-0.5, 1.5, (5000, 3))
    inside = (q > 0.037).all(axis=1) & (q < 0.963).all(axis=1)
    outside = (q < -0.02).any(axis=1) | (q > 1.02).any(axis=1)
    c = s.contains(q)
    assert c[inside].all() and not c[outside].any()


def test_shell_surface_closed_outward(tmp_path: Path) -> None:
    """Shell cloud: STL closed (edges shared by exactly 2 faces), consistently wound, outward
    (signed volume positive and equal to the kept tetrahedra's volume)."""
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


def box_points(n: int, seed: int) -> npt.NDArray[np.float64]:
    return np.random.default_rng(seed).random((n, 3)) * BOX


BOX = np.array([0.6, 0.4, 0.3])
R1, R2 = 0.05, 0.25  # the shell test robot's radii (m): a 5 cm unreachable cavity


@pytest.mark.parametrize(("n", "shell_low", "box_low", "interior_out"),
                         [(5000, -0.13, -0.10, 0.04), (20000, -0.08, -0.06, 0.005),
                          (80000, -0.05, -0.04, 0.0005)])
def test_analytic_shell_and_box(n: int, shell_low: float, box_low: float, interior_out: float) -> None:
    """Alpha "auto" on analytic clouds at 5k/20k/80k samples: volumes a little below the truth (samples
    never reach the boundary), nothing more than 1 cm outside inside, few points more than 1 cm inside
    left out, and from 20,000 samples the shell's 5 cm cavity stays empty (one radius large enough for
    the sparse outer layer, 2.5 x the 95th percentile of the 8-NN distance, filled it at 20,000)."""
    rng = np.random.default_rng(11)
    q = np.r_[rng.uniform(-0.3, 0.3, (30000, 3)), rng.uniform(-R1, R1, (3000, 3))]
    r = np.linalg.norm(q, axis=1)
    shell = alpha_shape(shell_points(n, R1, R2, seed=3))
    assert shell.method == "alpha-shape"
    assert shell_low < shell.volume / (4 / 3 * np.pi * (R2**3 - R1**3)) - 1 < 0
    c = shell.contains(q)
    assert not c[r > R2 + 0.01].any()
    assert (~c[(r > R1 + 0.01) & (r < R2 - 0.01)]).mean() < interior_out
    if n >= 20000:
        assert not c[r < R1 - 0.005].any()
    qb = rng.uniform(-0.1, 0.7, (30000, 3))
    box = alpha_shape(box_points(n, seed=3))
    assert box_low < box.volume / float(np.prod(BOX)) - 1 < 0
    cb = box.contains(qb)
    assert not cb[((qb < -0.01) | (qb > BOX + 0.01)).any(axis=1)].any()
    assert (~cb[((qb > 0.01) & (qb < BOX - 0.01)).all(axis=1)]).mean() < interior_out


def test_planar_points_give_a_thickened_plane() -> None:
    """Coplanar points (a planar robot): the 2-D alpha shape in their plane, 1 mm thick on each side,
    closed and outward; points of the plane inside it are inside, 2 mm off the plane or beyond its
    outline are outside. The annulus's hole stays open."""
    rng = np.random.default_rng(4)
    ang, rad = rng.uniform(-np.pi, np.pi, 8000), rng.uniform(0.1, 0.4, 8000)
    tilt = np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    p = np.c_[rad * np.cos(ang), rad * np.sin(ang), np.zeros(8000)] @ tilt.T + [0.1, 0.2, 0.3]
    s = alpha_shape(p)
    assert isinstance(s, FlatShape) and s.method == "planar-alpha-shape" and s.warning is None
    assert s.half_thickness == 1e-3
    counts, consistent = edge_counts(s.vertices[s.triangles])
    assert (counts == 2).all() and consistent
    assert signed_volume(s.vertices[s.triangles]) == pytest.approx(s.volume, rel=1e-6)
    assert -0.06 < s.volume / (np.pi * (0.4**2 - 0.1**2) * 2e-3) - 1 < 0
    def at(rr: float, off: float) -> npt.NDArray[np.float64]:
        a = np.linspace(-3, 3, 50)
        return np.c_[rr * np.cos(a), rr * np.sin(a), np.full(50, off)] @ tilt.T + [0.1, 0.2, 0.3]
    assert s.contains(at(0.25, 0.0)).all() and s.contains(at(0.25, 0.0009)).all()
    assert not s.contains(at(0.25, 0.002)).any() and not s.contains(at(0.25, -0.002)).any()
    assert not s.contains(at(0.05, 0.0)).any() and not s.contains(at(0.42, 0.0)).any()


ARC = np.linspace(0, 2, 300)


@pytest.mark.parametrize(("what", "points", "inside", "outside"), [
    ("curve", np.c_[0.3 * np.cos(ARC), 0.3 * np.sin(ARC), np.zeros(300)],
     [[0.3, 0.0, 0.0], [0.3 * np.cos(1.0), 0.3 * np.sin(1.0), 0.0009]],
     [[0.3, 0.0, 0.002], [-0.3, 0.0, 0.0]]),
    ("collinear", np.c_[np.linspace(0, 0.5, 50), np.zeros(50), np.full(50, 0.2)],
     [[0.25, 0.0009, 0.2], [0.0, 0.0, 0.2009]], [[0.25, 0.002, 0.2], [0.52, 0.0, 0.2]]),
])
def test_curves_lines_and_points_are_thickened(what: str, points: npt.NDArray[np.float64],
                                              inside: list[list[float]], outside: list[list[float]]) -> None:
    """One joint (an arc or a segment): its hull in its plane or line grown by 1 mm in every direction,
    with a warning naming what it is; reachable points are inside."""
    s = alpha_shape(points)
    assert isinstance(s, FlatShape) and s.method == "flat-hull"
    assert s.warning is not None and what in s.warning
    counts, consistent = edge_counts(s.vertices[s.triangles])
    assert len(s.triangles) > 0 and (counts == 2).all() and consistent
    assert s.contains(points).all() and s.contains(np.array(inside)).all()
    assert not s.contains(np.array(outside)).any()


def test_no_points_one_point_and_tiny_alpha() -> None:
    """No point or a single one: empty hull with a warning (no workspace to describe); an alpha smaller
    than every tetrahedron: the convex hull."""
    for p0, n in ((np.zeros((0, 3)), 0), (np.array([[0.1, 0.2, 0.3]] * 5), 1)):
        s = alpha_shape(p0)
        assert (s.method, len(s.triangles), s.volume) == ("convex-hull", 0, 0.0)
        assert s.warning is not None and f"{n} distinct points" in s.warning
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


def test_csv_rows_are_the_bytes_of_python_formatting() -> None:
    """``format_rows`` (numpy) writes exactly what ``%`` formatting writes, on values that stress the
    rounding: exact ties (1/128 = 0.0078125), values next to a half unit, signed zeros, tiny negatives,
    4-digit whole parts, ``%d`` of negative fractions; and the fallbacks (non-finite, huge, other format)."""
    from robwot_sim.workspace.io import format_rows

    rng = np.random.default_rng(0)
    n = 50000
    fmt = "%.6f,%.6f,%.6f,%d" + ",%.6f" * 7
    t = rng.normal(size=(n, 11)) * rng.choice([1e-8, 1e-3, 1.0, 30.0, 9999.0], size=(n, 11))
    t[:, 3] = rng.integers(-2, 3, n) * 0.75
    t[::7, 0] = (rng.integers(-10**7, 10**7, len(t[::7])) + 0.5) / 1e6
    t[::11, 1], t[::13, 2], t[::17, 4], t[::19, 5], t[::23, 6] = 1 / 128, -0.0, -1e-9, 5e-7, 2.5e-6
    assert format_rows(fmt, t) == "".join(fmt % tuple(r) + "\n" for r in t.tolist()).encode()
    reach = "%.6f,%.6f,%.6f,%d,%d,%d,%.6f"
    u = np.column_stack([t[:, :3], rng.integers(0, 5000, (n, 3)), rng.random(n)])
    assert format_rows(reach, u) == "".join(reach % tuple(r) + "\n" for r in u.tolist()).encode()
    odd = np.array([[np.inf, 1.0], [1e13, -2.0]])
    assert format_rows("%.6f,%d", odd) == b"inf,1\n10000000000000.000000,-2\n"
    assert format_rows("%.2e", np.array([[1234.5]])) == b"1.23e+03\n"


def test_interior_thinning_keeps_the_surface() -> None:
    """Thinning deep interior points: with one radius and 2 layers the surface is identical to no
    thinning; with the default single layer the volume changes by < 0.1 % (one radius, and auto) and
    the triangulated cloud is much smaller."""
    p = np.random.default_rng(7).random((20000, 3))
    auto_full, auto_thinned = alpha_shape(p, thin_layers=0), alpha_shape(p)
    assert auto_thinned.volume == pytest.approx(auto_full.volume, rel=1e-3)
    a = 0.15
    assert thin_interior(p, a, 2)[0].sum() < 0.9 * len(p)
    assert thin_interior(p, a, 1)[0].sum() < 0.6 * len(p)
    full, exact, default = (alpha_shape(p, a, thin_layers=n) for n in (0, 2, 1))

    def faces(s: AlphaShape) -> set[tuple[float, ...]]:
        return {tuple(sorted(map(tuple, t))) for t in s.vertices[s.triangles].tolist()}

    assert exact.volume == pytest.approx(full.volume, rel=1e-12)
    assert faces(exact) == faces(full)
    assert default.volume == pytest.approx(full.volume, rel=1e-3)


def test_nonmanifold_repair_looks_only_near_the_repair_and_keeps_what_a_full_scan_keeps() -> None:
    """The repair revisits only tetrahedra near the ones it added; it keeps exactly the tetrahedra that
    re-scanning every tetrahedron each round keeps (random shells whose alpha sets touch themselves)."""
    from scipy.spatial import Delaunay

    from robwot_sim.workspace import mesh
    from robwot_sim.workspace.alpha_shape import local_radii
    from robwot_sim.workspace.delaunay import circumspheres

    def full_scan(simplices: np.ndarray, neighbors: np.ndarray, kept: np.ndarray) -> np.ndarray:
        n, out = int(simplices.max()) + 1, kept.copy()
        e = np.sort(simplices[:, mesh._EDGE], axis=2)
        keys = e[:, :, 0] * n + e[:, :, 1]
        while (bad := mesh.nonmanifold_edges(simplices, neighbors, out, n)).size:
            out |= np.isin(keys, bad).any(axis=1)
        return out

    rng = np.random.default_rng(0)
    added = 0
    for k in range(4):
        p = rng.uniform(-1, 1, (8000, 3))
        p = p[np.linalg.norm(p, axis=1) > 0.3 + 0.2 * k]
        tri = Delaunay(p)
        s, nb = tri.simplices.astype(np.int64), tri.neighbors.astype(np.int64)
        kept = circumspheres(p, s)[1] <= (local_radii(p) * (0.5 + 0.2 * k))[s].max(axis=1)
        fast = mesh.fill_nonmanifold_edges(s, nb, kept)
        assert np.array_equal(fast, full_scan(s, nb, kept))
        added += int(fast.sum() - kept.sum())
    assert added > 0  # the repair had work to do
