"""Sure hits (robwot_sim.sim.surehit): the labels of World.collision_free_batch with and without them, on
20,000 samples of kuka with obstacles and of UR5 (decomposed meshes)."""

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
