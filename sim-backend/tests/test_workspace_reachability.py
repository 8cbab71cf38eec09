"""The reachability map: counts, direction bins and index per voxel; chunk order and coarsening do not
change it; generated beside the workspace files with the real World (shell robot, obstacle, kuka)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import generate_workspace
from robwot_sim.workspace.reachability import DIRECTIONS, LATTICE, ReachabilityMap, direction_bins

MODELS = Path(__file__).parent / "models" / "workspace"
BASE = np.array([0.1, -0.2, 0.5])
FloatArray = npt.NDArray[np.float64]


def read_map(path: Path) -> tuple[list[str], FloatArray]:
    lines = path.read_text().splitlines()
    return lines[0].split(","), np.loadtxt(lines[1:], delimiter=",", ndmin=2)


def rotation_with_z(z: FloatArray) -> FloatArray:
    """A rotation matrix whose third column is the unit vector ``z``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def test_direction_bins_pick_the_nearest_lattice_direction() -> None:
    """Each lattice direction falls in its own bin; a tilted axis in the bin of its nearest direction."""
    rots = np.stack([rotation_with_z(d) for d in LATTICE])
    assert direction_bins(rots).tolist() == list(range(DIRECTIONS))
    rng = np.random.default_rng(3)
    z = rng.normal(size=(200, 3))
    z /= np.linalg.norm(z, axis=1)[:, None]
    bins = direction_bins(np.stack([rotation_with_z(v) for v in z]))
    assert np.array_equal(bins, np.argmax(z @ LATTICE.T, axis=1))


def test_counts_directions_and_index() -> None:
    """Per voxel: samples, free ones, distinct bins of the free ones, index = bins / 64."""
    m = ReachabilityMap(0.125)
    pts = np.array([[0.01, 0.01, 0.01], [0.02, 0.1, 0.05], [0.03, 0.03, 0.03], [0.03, 0.03, 0.03],
                    [-0.01, 0.0, 0.0]])
    m.add(pts, np.array([True, True, True, False, True]), np.array([5, 7, 5, 9, 63], dtype=np.uint8))
    centres, samples, free, directions, index = m.columns()
    assert centres.tolist() == [[-0.0625, 0.0625, 0.0625], [0.0625, 0.0625, 0.0625]]
    assert samples.tolist() == [1, 4] and free.tolist() == [1, 3]
    assert directions.tolist() == [1, 2]  # bin 9 was colliding: not reached
    assert index.tolist() == [1 / 64, 2 / 64]


def test_chunk_order_merge_and_coarsening_do_not_matter(tmp_path: Path) -> None:
    """Chunks added in any order, maps merged, or a fine map coarsened: the same file."""
    rng = np.random.default_rng(1)
    pts = rng.uniform(-1.0, 1.0, size=(30_000, 3))
    free = rng.random(30_000) < 0.7
    bins = rng.integers(0, DIRECTIONS, 30_000).astype(np.uint8)
    whole = ReachabilityMap(0.25)
    whole.add(pts, free, bins)
    shuffled, merged = ReachabilityMap(0.25), ReachabilityMap(0.25)
    for a in (20_000, 0, 10_000):
        shuffled.add(pts[a:a + 10_000], free[a:a + 10_000], bins[a:a + 10_000])
        part = ReachabilityMap(0.25)
        part.add(pts[a:a + 10_000], free[a:a + 10_000], bins[a:a + 10_000])
        merged.merge(part)
    fine = ReachabilityMap(0.125)
    fine.add(pts, free, bins)
    files = []
    for i, m in enumerate((whole, shuffled, merged, fine.coarsen(2))):
        m.write_csv(tmp_path / f"{i}.csv")
        files.append((tmp_path / f"{i}.csv").read_bytes())
    assert files[1:] == files[:1] * 3
    header, rows = read_map(tmp_path / "0.csv")
    assert header == ["x", "y", "z", "samples", "free", "directions", "index"]
    assert rows.shape == (512, 7) and rows[:, 3].sum() == 30_000 and rows[:, 4].sum() == free.sum()
    with pytest.raises(ValueError, match="voxel"):
        whole.merge(fine)
    with pytest.raises(ValueError, match="voxel"):
        ReachabilityMap(0.001)


def test_auto_voxel_grows_until_voxels_are_well_sampled() -> None:
    """auto: the smallest 1 cm x 2^k voxel whose reached voxels average >= 32 free samples."""
    rng = np.random.default_rng(2)
    pts = rng.uniform(0.0, 0.64, size=(40_000, 3))
    m = ReachabilityMap(0.01)
    m.add(pts, np.ones(len(pts), dtype=bool), np.zeros(len(pts), dtype=np.uint8))
    # 40,000 uniform samples in a 0.64 m cube: 8 cm voxels hold 78 on average, 4 cm ones 9.8
    assert m.auto().voxel == pytest.approx(0.08)


def test_generated_beside_the_workspace(tmp_path: Path) -> None:
    """Shell robot with a box inside its shell: every sample counted once, voxels on the shell, no
    collision-free sample in a voxel wholly inside the box, summary describes the file."""
    centre, half = BASE + np.array([0.15, 0.0, 0.0]), 0.04
    with World() as w:
        w.load_robot(MODELS / "shell.urdf", robot_id="shell", base_position=BASE.tolist())
        w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [2 * half] * 3},
                        "position": centre.tolist()})
        summary = generate_workspace(w, "shell", samples=20_000, seed=2, workers=2, out_dir=tmp_path,
                                     reach_voxel=0.02)
    reach = summary["reachability"]
    assert reach == {"file": "reachability.csv", "voxel": 0.02, "voxels": reach["voxels"],
                     "directions": 64, "approachAxis": "z"}
    _, rows = read_map(tmp_path / "reachability.csv")
    assert len(rows) == reach["voxels"] > 100
    assert rows[:, 3].sum() == 20_000 and rows[:, 4].sum() == summary["collisionFree"] < 20_000
    r = np.linalg.norm(rows[:, :3] - BASE, axis=1)
    half_diag = 0.02 * np.sqrt(3) / 2
    assert r.min() >= 0.05 - half_diag and r.max() <= 0.25 + half_diag
    inside_box = np.all(np.abs(rows[:, :3] - centre) <= half - 0.01, axis=1)
    assert inside_box.sum() > 0 and not rows[inside_box, 4].any() and not rows[inside_box, 6].any()
    assert np.array_equal(rows[:, 6], rows[:, 5] / 64) and (rows[:, 5] <= rows[:, 4]).all()


def test_kuka_index_falls_towards_the_reach_boundary(tmp_path: Path) -> None:
    """As Reuleaux and REACH report for real arms: voxels at mid reach are reached from more approach
    directions than voxels near the boundary of the workspace (auto voxel)."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        summary = generate_workspace(w, "kuka", samples=40_000, seed=1, workers=2, out_dir=tmp_path)
    _, rows = read_map(tmp_path / "reachability.csv")
    assert 0.01 <= summary["reachability"]["voxel"] <= 0.5
    reached = rows[rows[:, 4] > 0]
    shoulder = np.array([0.0, 0.0, 0.36])  # lbr_iiwa_joint_2 height
    r = np.linalg.norm(reached[:, :3] - shoulder, axis=1)
    outer = reached[r > np.quantile(r, 0.9), 6].mean()
    middle = reached[(r > np.quantile(r, 0.3)) & (r < np.quantile(r, 0.6)), 6].mean()
    assert middle > 1.5 * outer
