"""Convex decomposition of collision meshes: concave meshes split, convex ones kept, results cached."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from robwot_sim.model import decompose as decompose_module
from robwot_sim.model.decompose import (
    cache_key,
    decompose,
    is_convex,
    remesh_resolution,
    slim,
    surface_points,
)


def box(lo: list[float], hi: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """Closed triangle mesh of an axis-aligned box."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    return corners, ConvexHull(corners).simplices.astype(np.uint32)


def u_shape() -> tuple[np.ndarray, np.ndarray]:
    """A closed U (0.3 m wide and high, arms 0.05 m thick): a U-shaped polygon in x-z extruded 0.1 m in y."""
    poly = [(0, 0), (0.3, 0), (0.3, 0.3), (0.25, 0.3), (0.25, 0.05), (0.05, 0.05), (0.05, 0.3), (0, 0.3)]
    v = np.array([[x, y, z] for y in (0.0, 0.1) for x, z in poly])
    cap = [(0, 1, 4), (1, 2, 3), (1, 3, 4), (0, 4, 5), (0, 5, 6), (0, 6, 7)]
    faces = list(cap) + [(a + 8, c + 8, b + 8) for a, b, c in cap]  # outward normals
    for i in range(8):
        j = (i + 1) % 8
        faces += [(i, j + 8, j), (i, i + 8, j + 8)]
    return subdivide(*subdivide(v, np.array(faces, dtype=np.uint32)))


def subdivide(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle into four (denser surface points for the coverage checks)."""
    verts = [tuple(p) for p in v]
    index = {p: i for i, p in enumerate(verts)}
    out = []

    def mid(a: int, b: int) -> int:
        p = tuple((np.array(verts[a]) + np.array(verts[b])) / 2)
        if p not in index:
            index[p] = len(verts)
            verts.append(p)
        return index[p]

    for a, b, c in f:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    return np.array(verts), np.array(out, dtype=np.uint32)


def inside_any(p: np.ndarray, parts: list[np.ndarray], tol: float = 2e-3) -> bool:
    for v in parts:
        eq = ConvexHull(v, qhull_options="QJ").equations
        if np.all(p @ eq[:, :3].T + eq[:, 3] <= tol):
            return True
    return False


def to_obj(v: np.ndarray, f: np.ndarray) -> str:
    vertices = "".join(f"v {a} {b} {c}\n" for a, b, c in v)
    return vertices + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f)


def read_obj(path: Path) -> np.ndarray:
    lines = path.read_text().splitlines()
    return np.array([[float(x) for x in ln.split()[1:4]] for ln in lines if ln.startswith("v ")])


def test_convex_mesh_is_kept(tmp_path: Path) -> None:
    """A box is convex: no parts, PyBullet's hull of it is exact."""
    v, f = box([0, 0, 0], [0.2, 0.1, 0.3])
    assert is_convex(v, f)
    d = decompose(v, f, "box", tmp_path)
    assert d.convex and d.parts == ()


def test_concave_mesh_is_split_into_parts_that_leave_the_gap_free(tmp_path: Path) -> None:
    """A U splits into several convex parts, all within the U's arms and bar: the inside of the U, which
    its single hull would fill, stays free."""
    v, f = u_shape()
    assert not is_convex(v, f)
    d = decompose(v, f, "u", tmp_path)
    assert not d.convex and len(d.parts) >= 3
    parts = [read_obj(p) for p in d.parts]
    gap = [np.array([x, 0.05, z]) for x in (0.08, 0.15, 0.22) for z in (0.1, 0.2, 0.28)]
    assert not any(inside_any(p, parts, tol=0.0) for p in gap)
    assert inside_any(np.array([0.15, 0.05, 0.2]), [v])  # ... which the U's hull holds


def test_parts_cover_the_whole_surface(tmp_path: Path) -> None:
    """No false "free": every point of the mesh surface lies inside a part (the shape never shrinks)."""
    v, f = u_shape()
    parts = [read_obj(p) for p in decompose(v, f, "u", tmp_path).parts]
    size = float(np.ptp(v, axis=0).max())
    eqs = [ConvexHull(p, qhull_options="QJ").equations for p in parts]
    pts = surface_points(v, f)
    outside = np.min([np.max(pts @ e[:, :3].T + e[:, 3], axis=1) for e in eqs], axis=0)
    assert outside.max() <= 2e-4 * size


def test_slim_hull_has_fewer_vertices_and_still_contains_every_point() -> None:
    """A finely sampled round surface (what the growing step leaves: every surface point a hull vertex)
    gets a hull of far fewer vertices that contains every point and exceeds the exact hull by little."""
    rng = np.random.default_rng(0)
    d = rng.normal(size=(5000, 3))
    pts = 0.05 * d / np.linalg.norm(d, axis=1)[:, None]  # sphere of radius 5 cm
    exact = ConvexHull(pts)
    v, tris = slim(pts, 1e-4)
    hull = ConvexHull(v)
    assert len(v) < len(exact.vertices) / 2
    assert tris.max() < len(v)
    assert np.max(pts @ hull.equations[:, :3].T + hull.equations[:, 3]) <= 1e-9  # contains every point
    assert np.max(v @ exact.equations[:, :3].T + exact.equations[:, 3]) <= 1e-3  # at most 1 mm larger
    box = rng.uniform(0, 0.1, size=(500, 3))  # nothing to merge: the exact hull, not a larger one
    assert len(slim(box, 1e-4)[0]) == len(ConvexHull(box).vertices)


def test_remesh_voxels_are_at_most_5_mm_within_bounds() -> None:
    """A long link is remeshed finer (a fatter remesh made false "colliding" labels); small ones at 50."""
    def mesh(size: float) -> np.ndarray:
        return np.array([[0.0, 0.0, 0.0], [size, 0.01, 0.01]])

    assert remesh_resolution(mesh(0.1)) == 50
    assert remesh_resolution(mesh(0.489)) == 98  # the UR5 forearm
    assert remesh_resolution(mesh(2.0)) == 100


def test_cache_is_reused_and_keyed_by_content_and_scale(tmp_path: Path) -> None:
    """A second call reads the parts back without recomputing; content or scale changes change the key."""
    v, f = u_shape()
    first = decompose(v, f, "k", tmp_path)
    stamp = [p.stat().st_mtime_ns for p in first.parts]
    again = decompose(v, f, "k", tmp_path)
    assert again == first and [p.stat().st_mtime_ns for p in again.parts] == stamp
    assert cache_key(b"abc", (1, 1, 1)) != cache_key(b"abd", (1, 1, 1))
    assert cache_key(b"abc", (1, 1, 1)) != cache_key(b"abc", (0.001, 0.001, 0.001))
    assert not list(tmp_path.glob(".*"))  # no temp folder left behind


def test_cache_key_includes_the_decomposition_parameters(monkeypatch: pytest.MonkeyPatch) -> None:
    """Other CoACD parameters, other parts: a cache written with the old ones is not reused."""
    before = cache_key(b"abc", (1, 1, 1))
    monkeypatch.setitem(decompose_module.COACD_PARAMS, "threshold", 0.03)
    assert cache_key(b"abc", (1, 1, 1)) != before


def test_new_meshes_are_decomposed_in_parallel_as_they_would_be_one_by_one(tmp_path: Path) -> None:
    """A robot's uncached concave meshes are decomposed side by side (one thread per core): the same
    parts, byte for byte, as one at a time; convex meshes are kept; a concave mesh becomes its parts."""
    import xml.etree.ElementTree as ET

    from robwot_sim.model.decompose import split_collisions

    v, f = u_shape()
    obj = tmp_path / "u.obj"
    obj.write_text(to_obj(v, f))
    bv, bf = box([0, 0, 0], [0.1, 0.1, 0.1])
    cube = tmp_path / "box.obj"
    cube.write_text(to_obj(bv, bf))
    meshes = {obj: (v, f), cube: (bv, bf)}
    links = "".join(f'<link name="l{i}"><collision><geometry><mesh filename="{m}" scale="{k} {k} {k}"/>'
                    "</geometry></collision></link>"
                    for i, (m, k) in enumerate([(obj, 1), (obj, 2), (obj, 3), (cube, 1)]))
    root = ET.fromstring(f'<robot name="r">{links}</robot>')
    used = split_collisions(root, tmp_path / "pool", lambda path: meshes.get(path))
    assert len(used) == 4
    counts = [len(link.findall("collision")) for link in root.iter("link")]
    assert min(counts[:3]) >= 3 and counts[3] == 1  # the U split, the box kept
    scales = {cache_key(obj.read_bytes(), (k, k, k)): k for k in (1.0, 2.0, 3.0)}
    compared = 0
    for folder in used:
        if folder.name in scales:
            alone = decompose(v * scales[folder.name], f, folder.name, tmp_path / "alone")
            parts = sorted(folder.glob("part*.obj"))
            assert [p.read_bytes() for p in alone.parts] == [p.read_bytes() for p in parts]
            compared += 1
    assert compared == 3


def test_a_robot_with_many_parts_loads_from_a_long_cache_path(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """PyBullet breaks long URDF lines: the KUKA's parts (~26 per link) named by absolute path under a long
    cache path, one link per line, failed to load ("Cannot load URDF file"; a fresh CI cache). The prepared
    file has one element per line."""
    from robwot_sim.model.decompose import collision_cache
    from robwot_sim.sim.world import World

    real = collision_cache(tmp_path)  # the usual cache: its parts are reused, only the path is longer
    real.mkdir(parents=True, exist_ok=True)
    cache = tmp_path / ("long-cache-folder-name-" * 4) / "collision"
    cache.parent.mkdir(parents=True)
    cache.symlink_to(real)
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(cache))
    with World() as w:
        m = w.load_robot("kuka_iiwa/model.urdf")
        assert not w.check_collision(m.id, [0, 2.0, 0, -2.0, 0, 2.0, 0]).collision_free


def test_coacds_log_level_is_set_once_before_any_decomposition(monkeypatch: pytest.MonkeyPatch) -> None:
    """Meshes are decomposed on threads; CoACD's logger is not thread-safe (setting its level while another
    thread decomposed aborted a test run), so the level is set once per process, never while a
    decomposition runs: four concurrent decompositions set it once, before their first run."""
    from concurrent.futures import ThreadPoolExecutor

    import coacd

    events: list[str] = []
    real_level, real_run = coacd.set_log_level, coacd.run_coacd

    def level(name: str) -> None:
        events.append("level")
        real_level(name)

    def run(*args: object, **kwargs: object) -> object:
        events.append("run")
        return real_run(*args, **kwargs)

    monkeypatch.setattr(coacd, "set_log_level", level)
    monkeypatch.setattr(coacd, "run_coacd", run)
    monkeypatch.setattr(decompose_module, "_quiet", False)
    v, f = u_shape()
    with ThreadPoolExecutor(4) as pool:
        found = list(pool.map(lambda _: decompose_module.convex_parts(v, f), range(4)))
    assert all(len(parts) >= 3 for parts in found)
    assert events[0] == "level" and events.count("level") == 1 and events.count("run") == 4
