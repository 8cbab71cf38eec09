"""No contact hides between checked states: a thin plate placed so that a fast move only grazes it
(found by bisection against a fine reference sweep) is refused by the path check every time, while
checking only the planned states (one per 1/240 s, what the twin did before) lets some through."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from robwot_bench.fidelity import graze_trials
from robwot_sim.sim.world import World


def test_grazing_plates_are_never_validated() -> None:
    """Plates grazed by up to ~2 mm: all refused by check_path; the planned states alone miss some."""
    with World() as w:
        m = w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        g = graze_trials(w, m.id, np.random.default_rng(5), 10)
    assert g.refused == g.grazes == 10
    assert g.planned_states_missed >= 1  # the planned states alone were not enough: this test has teeth


def _gap(w: World, rid: str, other: str) -> float:
    """Exact closest distance (m) between the robot and an obstacle, from PyBullet's distance query."""
    import pybullet as pb

    ids = {n: b for b, n in w.scene.table.names.items()}
    pts = pb.getClosestPoints(ids[rid], ids[other], 1.0, physicsClientId=w.scene.bullet.cid)
    return min(p[8] for p in pts)


def test_the_clearance_is_kept_to_the_millimetre_and_can_be_configured() -> None:
    """A sphere beside the middle of a swing about joint 1 (its ends far from it): the path is refused
    when the exact closest distance along it (PyBullet's distance query on 60 states) is below the robot's
    clearance (default 2 mm; 15 mm when loaded with it) and accepted when it is above."""
    start = np.array([-0.4, 0.6, 0, -0.6, 0, 0, 0], dtype=float)
    target = np.array([0.4, 0.6, 0, -0.6, 0, 0, 0], dtype=float)
    seen = {"refused": 0, "accepted": 0}
    with World() as w:
        for rid, clearance, base in (("k2", 0.002, 0.0), ("k15", 0.015, 5.0)):
            w.load_robot("kuka_iiwa/model.urdf", robot_id=rid, clearance=clearance,
                         base_position=(base, 0, 0))
            assert w.robot_model(rid).clearance == clearance
            p = np.array(w.fk(rid, ((start + target) / 2).tolist()).position)
            out = (p - np.array([base, 0, 0])) * np.array([1, 1, 0])
            out /= np.linalg.norm(out)
            w.add_obstacle({"name": f"s{rid}", "shape": {"type": "sphere", "radius": 0.02},
                            "position": (p + 0.3 * out).tolist()})
            for d in (0.051, 0.0515, 0.052, 0.053, 0.055, 0.058, 0.062, 0.066, 0.07, 0.075, 0.08):
                w.move_obstacle(f"s{rid}", (p + (0.02 + d) * out).tolist())
                gaps = []
                for t in np.linspace(0, 1, 60):
                    w.set_joint_positions(rid, (start + t * (target - start)).tolist())
                    gaps.append(_gap(w, rid, f"s{rid}"))
                w.set_joint_positions(rid, start.tolist())
                gap = min(gaps)
                if gap <= 0 or abs(gap - clearance) < 3e-4:
                    continue  # touching, or too close to the boundary for a 60-state reference
                free = w.check_path(rid, target.tolist()).collision_free
                assert free == (gap > clearance), (rid, gap)
                seen["accepted" if free else "refused"] += 1
    assert seen["refused"] >= 2 and seen["accepted"] >= 2, seen


_BOXES = [(0.5, 0.0, 0.4), (-0.3, 0.45, 0.7), (0.0, -0.55, 0.2), (0.2, 0.3, 1.1)]


def _kuka_among_boxes(w: World) -> Any:
    """A KUKA among four 20 cm boxes; its scene entry."""
    w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
    for k, (x, y, z) in enumerate(_BOXES):
        w.add_obstacle({"name": f"box{k}", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]},
                        "position": [x, y, z]})
    return w.scene.entry("kuka")


def _first_contact_by_bullet(e: Any, q0: np.ndarray, q1: np.ndarray) -> tuple[float | None, int]:
    """The reference: the first state along q0 -> q1 that Bullet finds closer than the clearance (None when
    there is none), asking at every state the path check would visit; and the states asked."""
    from robwot_sim.sim.sweep import substeps

    n = substeps(q0, q1, e.guard.reach, e.guard.max_sweep)
    for i in range(1, n + 1):
        e.bound.apply(q0 + (q1 - q0) * (i / n))
        if not e.checker.is_free(e.clearance):
            return i / n, i
    return None, n


def _random_paths(w: World, e: Any, rng: np.random.Generator) -> Any:
    """60 random straight paths of the KUKA that start free; each as (q0, q1)."""
    lo, hi = w.robot_model("kuka").limits()
    for _ in range(60):
        q0, q1 = rng.uniform(lo, hi), rng.uniform(lo, hi)
        e.bound.apply(q0)
        if e.checker.is_free(e.clearance):
            yield q0, q1


def test_skipping_distance_queries_far_from_obstacles_finds_the_same_first_contact() -> None:
    """The path check measures the distance to other bodies only when the travel since the last
    measurement could have used up the gap (conservative advancement). On 60 random paths among boxes it
    reports the same first state closer than the clearance as measuring at every state, with a tenth of the
    distance queries."""
    from robwot_sim.sim.pathcheck import first_contact

    rng = np.random.default_rng(11)
    with World() as w:
        e = _kuka_among_boxes(w)
        queries = {"gap": 0}
        gap = e.checker.gap

        def counted(cap: float) -> float:
            queries["gap"] += 1
            return gap(cap)

        e.checker.gap = counted  # type: ignore[method-assign]
        hits = states = 0
        for q0, q1 in _random_paths(w, e, rng):
            got = first_contact(e.bound, e.checker, q0, q1, e.guard, e.clearance)
            want, asked = _first_contact_by_bullet(e, q0, q1)
            states += asked
            assert (got[0] if got else None) == want
            hits += want is not None
    assert 10 <= hits < 60  # both outcomes occur
    assert queries["gap"] < states / 5  # measured: 4,977 for 55,614 states


def test_states_the_bounds_find_free_give_the_same_first_contact(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """With the outer bounds loaded, the states they find free are not asked of Bullet: on 60 random paths
    among boxes the path check still reports the same first state closer than the clearance as Bullet at
    every state, and the bounds decided at least a third of the states."""
    from robwot_sim.sim import kernels
    from robwot_sim.sim.pathcheck import first_contact

    assert kernels.kernels_ready(timeout=kernels.KERNELS_WAIT)
    rng = np.random.default_rng(12)
    with World() as w:
        e = _kuka_among_boxes(w)
        assert e.checker.sure_free is not None
        passed = {"sure": 0, "states": 0}
        sure_free = e.checker.sure_free

        def counted(states: np.ndarray, clearance: float, unsure: int) -> tuple[np.ndarray, int]:
            got, tested = sure_free(states, clearance, unsure)
            passed["sure"] += int(got[:tested].sum())
            passed["states"] += tested
            return got, tested

        monkeypatch.setattr(e.checker, "sure_free", counted)
        hits = 0
        for q0, q1 in _random_paths(w, e, rng):
            got = first_contact(e.bound, e.checker, q0, q1, e.guard, e.clearance)
            want, _ = _first_contact_by_bullet(e, q0, q1)
            assert (got[0] if got else None) == want
            hits += want is not None
    assert 10 <= hits < 60  # both outcomes occur
    assert passed["sure"] > passed["states"] / 3, passed


def test_a_path_the_bounds_find_free_throughout_asks_bullet_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A short swing of the KUKA among boxes, far from all of them: with the outer bounds loaded, its
    check asks Bullet about no state (its ends, whose clearance sets the path's, and its start's contact
    included) and finds it free with the guard's clearance, as Bullet does at every state; ending inside a
    box, the same check finds the contact Bullet finds."""
    from robwot_sim.sim import kernels

    assert kernels.kernels_ready(timeout=kernels.KERNELS_WAIT)
    start = np.array([0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0])
    target = start + np.array([0.3, 0.1, 0.0, 0.1, 0.0, 0.0, 0.0])
    with World() as w:
        e = _kuka_among_boxes(w)
        asked = {"bullet": 0}
        is_free = e.checker.is_free

        def counted(*args: Any, **kwargs: Any) -> bool:
            asked["bullet"] += 1
            return is_free(*args, **kwargs)

        assert _first_contact_by_bullet(e, start, target)[0] is None
        w.set_joint_positions("kuka", start.tolist())
        monkeypatch.setattr(e.checker, "is_free", counted)
        w.check_path("kuka", target.tolist())  # the first check builds the bounds (asking Bullet meanwhile)
        asked["bullet"] = 0
        report = w.check_path("kuka", target.tolist())
        assert report.collision_free and asked["bullet"] == 0
        assert w.motion_clearance("kuka", target.tolist()) == e.clearance
        w.move_obstacle("box0", w.fk("kuka", target.tolist()).position)
        assert not w.check_path("kuka", target.tolist()).collision_free
        assert asked["bullet"] > 0


def _reach_observed(robot_urdf: str, configurations: int) -> tuple[np.ndarray, np.ndarray]:
    """The guard's reach per joint, and the largest travel per radian of any collision point (the vertices of
    the links' shapes) seen when each joint alone turns by 0.01 rad from random configurations."""
    import pybullet as pb

    from robwot_sim.model.rotations import quat_matrix
    from robwot_sim.sim.robot_shapes import link_parts

    with World() as w:
        w.load_robot(robot_urdf, robot_id="r")
        e = w.scene.entry("r")
        robot, cid = e.bound, e.bound.bullet.cid
        links = range(pb.getNumJoints(robot.body, physicsClientId=cid))
        parts = {ln: link_parts(cid, robot.body, ln) for ln in links}
        points = {ln: np.concatenate(p) for ln, p in parts.items() if p}

        def placed(q: np.ndarray) -> np.ndarray:
            robot.apply(q)
            frames = {ln: robot.bullet.link_frame(robot.body, ln) for ln in points}
            return np.concatenate([p @ quat_matrix(frames[ln][1]).T + np.asarray(frames[ln][0])
                                   for ln, p in points.items()])

        rng, step = np.random.default_rng(2), 0.01
        seen = np.zeros(robot.dof)
        for _ in range(configurations):
            q = rng.uniform(robot.lower, robot.upper - step)
            at = placed(q)
            for k in range(robot.dof):
                moved = placed(q + step * np.eye(robot.dof)[k])
                seen[k] = max(seen[k], float(np.linalg.norm(moved - at, axis=1).max()) / step)
        return e.guard.reach, seen


@pytest.mark.parametrize("urdf", ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf"])
def test_no_collision_point_travels_farther_per_radian_than_its_joints_reach(urdf: str) -> None:
    """The sweep bound is sound (no point of a link's collision shapes moves farther than reach x angle) and,
    for the KUKA's first two joints (the largest reaches), within 10 % of the farthest travel seen (joint
    1's was the chain's length from its frame, 1.198 m per radian, 28 % above what any point travels)."""
    reach, seen = _reach_observed(urdf, 60)
    assert (seen <= reach * (1 + 1e-3)).all(), (reach, seen)
    if urdf.startswith("kuka"):
        assert (seen[:2] >= 0.9 * reach[:2]).all(), (reach, seen)
