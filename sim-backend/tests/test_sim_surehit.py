"""Sure hits (robwot_sim.sim.surehit): the labels of World.collision_free_batch with them against Bullet
alone, on every bundled robot and UR5 (decomposed meshes, self-collision), and the obstacle grid against
brute force."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robwot_bench.bounds import BUNDLED
from robwot_bench.surehits import measure
from robwot_sim.sim import surehit
from robwot_sim.sim.world import World

SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
SAMPLES = 20_000


@pytest.mark.parametrize(("robot", "scene"), [*((name, "obstacles-239.json") for name in BUNDLED),
                                              ("kuka", "obstacles-4.json"), ("ur5", "-")])
def test_same_labels_as_bullet_alone(robot: str, scene: str) -> None:
    """20,000 seeded rows labelled with the sure-hit test and by Bullet alone (``bench:surehits``): the same
    labels, though Bullet checks other rows before each row in the two (it would keep a grazing contact's
    points from one check to the next: the xArm6 with its gripper flipped ~120 of 20,000 in reverse order,
    but for ``client.Recheck``), and none a sure hit of a configuration fresh Bullet distance
    queries find apart. Sure hits are found for every robot."""
    r = measure(robot, None if scene == "-" else scene, SAMPLES, seed=12345)
    assert (r["unsound"], r["differ"], r["order"]) == (0, 0, 0)
    assert float(r["hits"]) > 0.05


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


def test_obstacle_grid_against_brute_force() -> None:
    """The obstacle grid's hits are certain and nearly all: over 5,000 kuka rows among 239 obstacles
    (box, sphere, cylinder), every ball it finds lies more than DEPTH inside some obstacle by the exact
    signed distances of every ball to every obstacle, and it finds at least 99 % of the rows that test
    finds (a ball in an obstacle other than its voxel's nearest one is missed)."""
    from robwot_sim.model.fk import chain_frames

    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="r")
        w.load_scene(SCENES / "obstacles-239.json")
        lo, hi = w.robot_model("r").limits()
        qs = np.random.default_rng(7).uniform(lo, hi, size=(5000, len(lo)))
        sure = w.queries.sure_hits("r")
    sure.pairs = []  # the obstacle part alone
    assert sure.grid is not None
    obs = sure.grid.obs
    assert obs.count == 239
    frames = chain_frames(sure.fks, qs)
    balls = np.concatenate([p[:, None, :] + np.einsum("nij,kj->nki", r, lb.centres)
                            for (p, r), lb in zip(frames, sure.links, strict=True)], axis=1)
    inside = np.zeros(balls.shape[:2], dtype=bool)
    for j in range(obs.count):
        sd = obs.sdf(int(obs.kind[j]), balls, np.full(len(qs), j, dtype=np.intp))
        inside |= sd < sure.radii - surehit.DEPTH
    found = sure.grid.hits(balls.transpose(0, 2, 1), sure.radii)
    assert not (found & ~inside).any()
    got, ref = sure.hits(qs), inside.any(axis=1)
    assert np.array_equal(got, found.any(axis=1))
    assert got.sum() >= 0.99 * ref.sum() > 0.3 * len(qs)
