"""generate_workspace end to end with the real World: analytic shell and planar arm, files, seeds,
obstacles, bad input."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from robwot_sim.errors import InvalidParams, SimError, UnknownRobot
from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import generate_workspace
from robwot_sim.workspace.io import read_stl

MODELS = Path(__file__).parent / "models" / "workspace"
R1, R2 = 0.05, 0.25  # shell.urdf radial limits (m)
SHELL_VOLUME = 4.0 / 3.0 * math.pi * (R2**3 - R1**3)
BASE = np.array([0.1, -0.2, 0.5])
FloatArray = npt.NDArray[np.float64]
ShellRun = tuple[dict[str, Any], Path, list[tuple[str, int, int]]]


def read_csv(path: Path) -> tuple[list[str], FloatArray]:
    lines = path.read_text().splitlines()
    return lines[0].split(","), np.loadtxt(lines[1:], delimiter=",", ndmin=2)


def inside_mesh(tris: FloatArray, q: FloatArray) -> npt.NDArray[np.bool_]:
    """Ray-casting parity test of points against a closed triangle mesh (Moller-Trumbore)."""
    d = np.array([0.5377, 0.8310, 0.1427])
    d /= np.linalg.norm(d)
    a, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > 1e-15
    a, e1, e2, h, inv = a[ok], e1[ok], e2[ok], h[ok], 1.0 / det[ok]
    hits = np.zeros(len(q), dtype=np.int64)
    for i, p in enumerate(q):
        s = p - a
        u = np.einsum("ij,ij->i", s, h) * inv
        qv = np.cross(s, e1)
        v = (qv @ d) * inv
        t = np.einsum("ij,ij->i", e2, qv) * inv
        hits[i] = int(((u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)).sum())
    return hits % 2 == 1


@pytest.fixture(scope="module")
def shell(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ShellRun]:
    out = tmp_path_factory.mktemp("shell")
    events: list[tuple[str, int, int]] = []
    with World() as w:
        w.load_robot(MODELS / "shell.urdf", robot_id="shell", base_position=BASE.tolist())
        summary = generate_workspace(w, "shell", samples=80_000, seed=1, workers=2, out_dir=out,
                                     progress=lambda s, d, t: events.append((s, d, t)))
    yield summary, out, events


def test_shell_volume_within_5_percent(shell: tuple[dict[str, Any], Path, Any]) -> None:
    """The alpha-shape volume of the shell robot is within 5 % of 4/3 pi (r2^3 - r1^3)."""
    summary, _, _ = shell
    assert summary["method"] == "alpha-shape" and "warning" not in summary
    assert summary["volume"] == pytest.approx(SHELL_VOLUME, rel=0.05)


def test_shell_summary_and_progress(shell: tuple[dict[str, Any], Path, list[tuple[str, int, int]]]) -> None:
    """WorkspaceSummary fields (Contract 2), bounds = base +- r2, stages reported in order to completion."""
    summary, _, events = shell
    assert set(summary) == {"samples", "collisionFree", "bounds", "reachBounds", "alpha", "method", "volume",
                            "seed", "reachability", "timings", "versions"}
    assert (summary["samples"], summary["collisionFree"], summary["seed"]) == (80_000, 80_000, 1)
    assert np.allclose(summary["bounds"]["min"], BASE - R2, atol=0.01)
    assert np.allclose(summary["bounds"]["max"], BASE + R2, atol=0.01)
    assert np.allclose(summary["reachBounds"]["min"], BASE - R2, atol=1e-4)  # the true extremes
    assert np.allclose(summary["reachBounds"]["max"], BASE + R2, atol=1e-4)
    assert 0 < summary["alpha"] < R1
    assert set(summary["timings"]) == {"sample", "collide", "alpha", "write"}
    assert all(v >= 0 for v in summary["timings"].values())
    assert set(summary["versions"]) == {"robwot_sim", "pybullet", "numpy", "scipy"}
    stages = [s for s, _, _ in events]
    assert [s for i, s in enumerate(stages) if i == 0 or stages[i - 1] != s] == ["sample", "collide", "alpha",
                                                                                  "write"]
    for stage in ("sample", "collide", "alpha", "write"):
        last = [e for e in events if e[0] == stage][-1]
        assert last[1] == last[2]
    collide = [d for s, d, _ in events if s == "collide"]
    assert collide == sorted(collide) and len(collide) > 2


def test_shell_csv(shell: tuple[dict[str, Any], Path, Any]) -> None:
    """workspace.csv: header, one row per sample, every point on the analytic shell (m, world frame)."""
    _, out, _ = shell
    header, rows = read_csv(out / "workspace.csv")
    assert header == ["x", "y", "z", "collision_free"]
    assert rows.shape == (80_000, 4)
    r = np.linalg.norm(rows[:, :3] - BASE, axis=1)
    assert r.min() >= R1 - 2e-6 and r.max() <= R2 + 2e-6
    assert set(np.unique(rows[:, 3])) == {1.0}


def test_shell_stl_closed_outward(shell: tuple[dict[str, Any], Path, Any]) -> None:
    """workspace.stl: every edge in exactly 2 faces, each directed edge once, signed volume = volume."""
    summary, out, _ = shell
    tris, normals = read_stl(out / "workspace.stl")
    _, idx = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    t = idx.reshape(-1, 3)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    _, dcount = np.unique(directed, axis=0, return_counts=True)
    _, ucount = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    assert (ucount == 2).all() and (dcount == 1).all()
    signed = np.einsum("ij,ij->i", tris[:, 0], np.cross(tris[:, 1], tris[:, 2])).sum() / 6.0
    assert signed > 0
    assert signed == pytest.approx(summary["volume"], rel=1e-4)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    assert (np.einsum("ij,ij->i", n, normals) >= 0).all()


def test_shell_inside_outside(shell: tuple[dict[str, Any], Path, Any]) -> None:
    """Points more than 1 cm inside the analytic shell are inside the STL; 1 cm outside are outside."""
    _, out, _ = shell
    tris, _ = read_stl(out / "workspace.stl")
    rng = np.random.default_rng(11)
    d = rng.normal(size=(600, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = rng.uniform(0.0, R2 + 0.05, 600)
    inside = (r > R1 + 0.01) & (r < R2 - 0.01)
    outside = (r < R1 - 0.01) | (r > R2 + 0.01)
    got = inside_mesh(tris, BASE + d * r[:, None])
    assert inside.sum() > 200 and outside.sum() > 100
    assert got[inside].all()
    assert not got[outside].any()


def test_planar_arm_gets_a_thickened_plane(tmp_path: Path) -> None:
    """A planar arm: its annulus 0.1 <= r <= 0.7 at z = 0.1 as a 2 mm slab (planar-alpha-shape): the STL
    holds reachable targets of the plane and not the hole, nor targets 3 mm off the plane."""
    with World() as w:
        w.load_robot(MODELS / "planar2.urdf", robot_id="planar")
        summary = generate_workspace(w, "planar", samples=5000, seed=3, workers=2, out_dir=tmp_path)
    assert summary["method"] == "planar-alpha-shape" and "warning" not in summary
    assert summary["halfThickness"] == 1e-3
    # the reach: 0.4 + 0.3 m around the shoulder, in the plane z = 0.1
    assert np.allclose(summary["reachBounds"]["min"], [-0.7, -0.7, 0.1], atol=1e-5)
    assert np.allclose(summary["reachBounds"]["max"], [0.7, 0.7, 0.1], atol=1e-5)
    assert summary["volume"] == pytest.approx(math.pi * (0.7**2 - 0.1**2) * 2e-3, rel=0.08)
    a = np.linspace(-3.0, 3.0, 12)
    ring = np.c_[0.4 * np.cos(a), 0.4 * np.sin(a), np.full(12, 0.1)]
    tris, _ = read_stl(tmp_path / "workspace.stl")
    assert inside_mesh(tris, ring).all()
    assert not inside_mesh(tris, ring + np.array([0, 0, 0.003])).any()
    assert not inside_mesh(tris, ring * [0.1, 0.1, 1]).any()
    assert np.allclose(summary["bounds"]["min"], [-0.7, -0.7, 0.1], atol=0.01)
    assert np.allclose(summary["bounds"]["max"], [0.7, 0.7, 0.1], atol=0.01)
    _, rows = read_csv(tmp_path / "workspace.csv")
    r = np.hypot(rows[:, 0], rows[:, 1])
    assert r.min() >= 0.1 - 1e-6 and r.max() <= 0.7 + 1e-6 and r.min() < 0.12
    assert np.allclose(rows[:, 2], 0.1)
    assert len(read_stl(tmp_path / "workspace.stl")[0]) > 0


def test_same_seed_same_files(tmp_path: Path) -> None:
    """Same seed: byte-identical CSV and STL; another seed: other points, similar bounds."""
    outs = [tmp_path / n for n in ("a", "b", "c")]
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        sums = [generate_workspace(w, "kuka", samples=3000, seed=s, workers=2, out_dir=o, csv_joints=True)
                for s, o in zip((5, 5, 6), outs, strict=True)]
    a, b, c = ((o / "workspace.csv").read_bytes() for o in outs)
    assert a == b and a != c
    assert (outs[0] / "workspace.stl").read_bytes() == (outs[1] / "workspace.stl").read_bytes()
    header, rows = read_csv(outs[0] / "workspace.csv")
    assert header == ["x", "y", "z", "collision_free", *(f"lbr_iiwa_joint_{i}" for i in range(1, 8))]
    assert rows.shape == (3000, 11)
    assert np.allclose(sums[0]["bounds"]["min"], sums[2]["bounds"]["min"], atol=0.1)
    assert np.allclose(sums[0]["bounds"]["max"], sums[2]["bounds"]["max"], atol=0.1)
    # every sample (free or not) lies in the reach box, which reaches the KUKA's true extremes: 1.261 m
    # up (0.36 + 0.42 + 0.4 + 0.081 m stretched), x and y as far as the samples nearly (<= 10 cm more)
    lo, hi = np.array(sums[0]["reachBounds"]["min"]), np.array(sums[0]["reachBounds"]["max"])
    assert (rows[:, :3] >= lo).all() and (rows[:, :3] <= hi).all()
    assert hi[2] == pytest.approx(1.261, abs=1e-4)
    assert (hi - rows[:, :3].max(axis=0) < 0.1).all() and (rows[:, :3].min(axis=0) - lo < 0.1).all()


def test_obstacle_removes_points(tmp_path: Path) -> None:
    """A box inside the shell: no collision-free point inside it, every point 6 mm clear of it free."""
    centre, half = BASE + np.array([0.15, 0.0, 0.0]), 0.04
    with World() as w:
        w.load_robot(MODELS / "shell.urdf", robot_id="shell", base_position=BASE.tolist())
        w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [2 * half] * 3},
                        "position": centre.tolist()})
        summary = generate_workspace(w, "shell", samples=20_000, seed=2, workers=2, out_dir=tmp_path)
    _, rows = read_csv(tmp_path / "workspace.csv")
    gap = np.abs(rows[:, :3] - centre).max(axis=1) - half  # < 0 inside the box (Chebyshev distance)
    free = rows[:, 3] == 1
    assert (gap < 0).sum() > 50
    assert not free[gap < 0].any()
    assert free[gap > 0.006].all()
    assert summary["collisionFree"] == int(free.sum()) < 20_000


def test_bad_input_changes_nothing(tmp_path: Path) -> None:
    """Unknown robot, bad samples/alpha/workers, unwritable outDir: structured errors, no files."""
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with World() as w:
        w.load_robot(MODELS / "planar2.urdf", robot_id="planar")
        with pytest.raises(UnknownRobot):
            generate_workspace(w, "nope", out_dir=tmp_path / "o1")
        for kwargs, param in (({"samples": 0}, "samples"), ({"alpha": -1.0}, "alpha"),
                              ({"reach_voxel": 0.001}, "reachVoxel"), ({"reach_voxel": "fine"}, "reachVoxel"),
                              ({"alpha": "big"}, "alpha"), ({"workers": 0}, "workers"),
                              ({"seed": -1}, "seed")):
            with pytest.raises(InvalidParams) as exc:
                generate_workspace(w, "planar", out_dir=tmp_path / "o2", **kwargs)
            assert exc.value.data["param"] == param
        with pytest.raises(SimError) as exc2:
            generate_workspace(w, "planar", samples=100, out_dir=blocker / "sub")
        assert exc2.value.data["param"] == "outDir"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_no_collision_free_sample(tmp_path: Path) -> None:
    """A robot buried in a box: zero free samples, hull fallback with a warning, null bounds, empty STL."""
    with World() as w:
        w.load_robot(MODELS / "shell.urdf", robot_id="shell", base_position=BASE.tolist())
        w.add_obstacle({"name": "crate", "shape": {"type": "box", "size": [1.0, 1.0, 1.0]},
                        "position": BASE.tolist()})
        summary = generate_workspace(w, "shell", samples=500, seed=1, workers=1, out_dir=tmp_path)
    assert summary["collisionFree"] == 0 and summary["volume"] == 0.0
    assert summary["method"] == "convex-hull" and "0 distinct points" in summary["warning"]
    assert summary["bounds"] == {"min": None, "max": None}
    assert len(read_stl(tmp_path / "workspace.stl")[0]) == 0
    _, rows = read_csv(tmp_path / "workspace.csv")
    assert rows.shape == (500, 4) and not rows[:, 3].any()
