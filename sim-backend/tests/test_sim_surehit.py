"""Sure hits (robwot_sim.sim.surehit): the labels of World.collision_free_batch with and without them, on
20,000 samples of kuka with obstacles, of the bundled UR3 (URDF cylinders) and of UR5 (decomposed meshes)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from robwot_bench.reference import example_robot
from robwot_sim.sim import surehit
from robwot_sim.sim.world import World

SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
UR3 = Path(__file__).resolve().parents[2] / "packages" / "cli" / "robots" / "ur3.urdf"
SAMPLES = 20_000
BoolArray = npt.NDArray[np.bool_]


@contextmanager
def no_sure_hits(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """Every row to Bullet, as before sure hits."""
    with monkeypatch.context() as m:
        m.setattr(surehit.SureHits, "hits", lambda self, qs: np.zeros(len(qs), dtype=bool))
        yield


def kuka(w: World) -> str:
    w.load_robot("kuka_iiwa/model.urdf", robot_id="r")
    w.load_scene(SCENES / "obstacles-4.json")
    return "r"


def ur3_cylinders(w: World) -> str:
    """The bundled UR3: URDF cylinders, which Bullet turns into hulls of its own (``unknown_file``)."""
    w.load_robot(str(UR3), robot_id="r")
    w.load_scene(SCENES / "obstacles-239.json")
    return "r"


def ur5(w: World) -> str:
    r = example_robot("ur5")
    w.load_robot(str(r.urdf), package_roots=r.package_roots, robot_id="r")
    return "r"


def label(load: Callable[[World], str], qs: npt.NDArray[np.float64] | None,
          monkeypatch: pytest.MonkeyPatch, sure: bool = True) -> tuple[BoolArray, int]:
    """Labels of ``qs`` (default: 20,000 seeded samples) in a fresh world, and how many were sure hits."""
    with World() as w:
        rid = load(w)
        if qs is None:
            lo, hi = w.robot_model(rid).limits()
            qs = np.random.default_rng(12345).uniform(lo, hi, size=(SAMPLES, len(lo)))
        if sure:
            return w.collision_free_batch(rid, qs), int(w._sure_hits(rid).hits(qs).sum())
        with no_sure_hits(monkeypatch):
            return w.collision_free_batch(rid, qs), 0


def samples(load: Callable[[World], str]) -> npt.NDArray[np.float64]:
    with World() as w:
        lo, hi = w.robot_model(load(w)).limits()
    return np.random.default_rng(12345).uniform(lo, hi, size=(SAMPLES, len(lo)))


def test_kuka_with_obstacles_same_labels(monkeypatch: pytest.MonkeyPatch) -> None:
    """kuka + obstacles-4: identical labels; ~9 % of the rows are sure hits (most of the colliding ones)."""
    qs = samples(kuka)
    new, sure = label(kuka, qs, monkeypatch)
    old, _ = label(kuka, qs, monkeypatch, sure=False)
    assert np.array_equal(new, old)
    assert sure > 0.5 * int((~old).sum()) > 0.05 * SAMPLES


def test_ur3_cylinder_hulls_same_labels(monkeypatch: pytest.MonkeyPatch) -> None:
    """The bundled UR3 among 239 obstacles: its links' hulls are Bullet's own (URDF cylinders); their balls
    come from the vertices Bullet holds. Identical labels; most colliding rows (~60 % of all) are sure
    hits."""
    qs = samples(ur3_cylinders)
    new, sure = label(ur3_cylinders, qs, monkeypatch)
    old, _ = label(ur3_cylinders, qs, monkeypatch, sure=False)
    assert np.array_equal(new, old)
    assert sure > 0.5 * int((~old).sum()) > 0.3 * SAMPLES


def test_ur5_meshes_same_labels_but_history(monkeypatch: pytest.MonkeyPatch) -> None:
    """UR5 (decomposed meshes, self-collision): the labels are the same except where Bullet's label
    depended on the configuration checked just before (a contact point kept from it; 1 row in 20,000
    here): there the new label is the one of the configuration checked on its own."""
    qs = samples(ur5)
    new, sure = label(ur5, qs, monkeypatch)
    old, _ = label(ur5, qs, monkeypatch, sure=False)
    differ = np.flatnonzero(new != old)
    assert len(differ) <= SAMPLES // 5000
    for i in differ:
        alone, _ = label(ur5, qs[i:i + 1], monkeypatch, sure=False)
        assert alone[0] == new[i]
    assert sure > 0.02 * SAMPLES


def test_obstacles_signed_distance() -> None:
    """The batched signed distances of box, sphere and cylinder at points of known distance, rotated
    and moved obstacles included."""
    quarter = [0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)]  # 90 degrees about z
    specs = [{"shape": {"type": "box", "size": [0.2, 0.4, 0.6]}, "position": [1.0, 0.0, 0.0],
              "orientation": quarter},
             {"shape": {"type": "sphere", "radius": 0.1}, "position": [0.0, 1.0, 0.0],
              "orientation": [0.0, 0.0, 0.0, 1.0]},
             {"shape": {"type": "cylinder", "radius": 0.1, "length": 0.4}, "position": [0.0, 0.0, 1.0],
              "orientation": [0.0, 0.0, 0.0, 1.0]}]
    obs = surehit._Obstacles(specs)
    assert obs.count == 3 and np.allclose(obs.reach, [np.linalg.norm([0.1, 0.2, 0.3]), 0.1,
                                                      np.hypot(0.1, 0.2)])
    # box turned 90 degrees: its 0.4 m side along world x
    box = obs.sdf(0, np.array([[1.5, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.3, 0.0]]),
                  np.zeros(3, dtype=np.intp))
    assert np.allclose(box, [0.3, -0.1, 0.2])
    sphere = obs.sdf(1, np.array([[[0.0, 1.5, 0.0], [0.0, 1.05, 0.0]]]), np.array([1]))
    assert np.allclose(sphere, [[0.4, -0.05]])
    cyl = obs.sdf(2, np.array([[0.0, 0.0, 1.5], [0.3, 0.0, 1.0], [0.0, 0.0, 1.0], [0.4, 0.0, 1.6]]),
                  np.full(4, 2, dtype=np.intp))
    assert np.allclose(cyl, [0.3, 0.2, -0.1, np.hypot(0.3, 0.4)])


def test_obstacle_pairs_as_by_brute_force() -> None:
    """The pairs found by the bounding-ball product miss none: over 5,000 kuka rows among 239 obstacles,
    the obstacle hits equal those of every link's balls tested against every tested obstacle (the
    ``MAX_OBSTACLES`` largest)."""
    from robwot_sim.model.fk import chain_frames

    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="r")
        w.load_scene(SCENES / "obstacles-239.json")
        lo, hi = w.robot_model("r").limits()
        qs = np.random.default_rng(7).uniform(lo, hi, size=(5000, len(lo)))
        sure = w._sure_hits("r")
    sure.pairs = []  # the obstacle part alone
    obs = sure.obstacles
    assert obs.count == surehit.MAX_OBSTACLES
    ref = np.zeros(len(qs), dtype=bool)
    for (p, r), lb in zip(chain_frames(sure.fks, qs), sure.links, strict=True):
        balls = p[:, None, :] + np.einsum("nij,kj->nki", r, lb.centres)
        for j in range(obs.count):
            sd = obs.sdf(int(obs.kind[j]), balls, np.full(len(qs), j, dtype=np.intp))
            ref |= (sd < lb.radii - surehit.DEPTH).any(axis=1)
    got = sure.hits(qs)
    assert np.array_equal(got, ref)
    assert got.sum() > 0.05 * len(qs)
