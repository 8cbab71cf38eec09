"""Self and environment collision: known cases, base contact, filtered pairs, fast path agreement (H1)."""

from __future__ import annotations

import numpy as np
import pybullet as pb
import pytest
from simhelp import KUKA, MODELS, PANDA, SCENES, XARM

from robwot_sim.errors import InvalidParams, OutOfLimits
from robwot_sim.sim.world import World


def test_free_and_self_colliding_configurations() -> None:
    """Kuka upright is free; folding joint 4 fully with joint 2 back makes links touch each other."""
    with World() as w:
        m = w.load_robot(KUKA)
        assert w.check_collision(m.id, [0.0] * 7).collision_free
        rep = w.check_collision(m.id, [0, 2.0, 0, -2.0, 0, 2.0, 0])
        assert not rep.collision_free
        assert all(c.a.body == m.id and c.b.body == m.id for c in rep.contacts)
        assert all(c.depth >= 0 for c in rep.contacts)


def test_environment_contact_names_pair_and_depth() -> None:
    """A box through the upright arm is reported as (robot link, obstacle) with a positive depth."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(
            {"name": "wall", "shape": {"type": "box", "size": [0.1, 0.4, 0.1]}, "position": [0.0, 0.0, 0.9]}
        )
        rep = w.check_collision(m.id)
        assert not rep.collision_free
        pairs = {(c.a.body, c.b.body, c.b.link) for c in rep.contacts}
        assert (m.id, "wall", None) in pairs
        wall = next(c for c in rep.contacts if c.b.body == "wall")
        assert wall.a.link in m.links and wall.depth > 0.01
        w.move_obstacle("wall", (1.5, 0.0, 0.9))
        assert w.check_collision(m.id).collision_free


def test_fixed_base_touching_static_obstacle_is_reported() -> None:
    """An obstacle touching only the fixed base (which never moves) is a collision."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(
            {
                "name": "block",
                "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
                "position": [0.12, 0.0, 0.05],
            }
        )
        rep = w.check_collision(m.id)
        assert not rep.collision_free
        assert any(c.b.body == "block" and c.a.link == "lbr_iiwa_link_0" for c in rep.contacts)
        assert not w.collision_free_batch(m.id, np.zeros((3, 7))).any()


def test_panda_always_touching_pair_is_filtered() -> None:
    """Panda link7/hand touch in every configuration: detected at load and filtered."""
    with World() as w:
        m = w.load_robot(PANDA)
        assert ("panda_link7", "panda_hand") in m.filtered_pairs
        ready = [0, -0.785, 0, -2.356, 0, 1.571, 0.785, 0.02]
        rep = w.check_collision(m.id, ready)
        assert rep.collision_free, rep.contacts
        k = w.load_robot(KUKA, base_position=(2, 0, 0))
        assert k.filtered_pairs == ()


def test_mimic_joint_followed_in_collision_and_state() -> None:
    """The mimic joint follows its master (q * -0.5 + 0.1), in PyBullet's state too."""
    with World() as w:
        m = w.load_robot(MODELS / "mimic.urdf")
        assert m.controllable == ("finger",)
        assert m.joint("finger_mimic").mimic is not None
        w.set_joint_positions(m.id, [0.4])
        e = w.scene.entry(m.id)
        follower = next(ji.idx for ji in w.scene.bullet.joints(e.bound.body) if ji.name == "finger_mimic")
        value = pb.getJointState(e.bound.body, follower, physicsClientId=w.scene.bullet.cid)[0]
        assert value == pytest.approx(0.4 * -0.5 + 0.1)


def _brute_force_free(w: World, robot_id: str, q: np.ndarray) -> bool:
    """Every link of the robot against every other body and every non-adjacent, unfiltered self pair,
    with getClosestPoints(distance=0): slow but exhaustive."""
    e = w.scene.entry(robot_id)
    b, cid, body = e.bound, w.scene.bullet.cid, e.bound.body
    b.apply(q)
    links = [-1, *range(pb.getNumJoints(body, physicsClientId=cid))]
    parent = {ji.idx: ji.parent_index for ji in w.scene.bullet.joints(body)}
    for other in w.scene.table.names:
        if other != body and pb.getClosestPoints(body, other, 0.0, physicsClientId=cid):
            return False
    for i, a in enumerate(links):
        for c in links[i + 1 :]:
            if parent.get(c) == a or parent.get(a) == c or (min(a, c), max(a, c)) in e.checker.filtered:
                continue
            if a in b.static_links and c in b.static_links:
                continue
            if pb.getClosestPoints(body, body, 0.0, linkIndexA=a, linkIndexB=c, physicsClientId=cid):
                return False
    return True


@pytest.mark.parametrize(("urdf", "scene"), [(KUKA, 66), (PANDA, 66), (XARM, 66), (KUKA, 239)])
def test_fast_batch_agrees_with_check_collision_and_brute_force(urdf: str, scene: int) -> None:
    """collision_free_batch == check_collision == exhaustive pairs on 150 random configs (the batch on
    Bullet's mirror world alone; with the outer bounds, whose rows Bullet checks in another order, the
    labels are compared in ``test_sim_outerbounds.py``)."""
    with World() as w:
        m = w.load_robot(urdf)
        w.load_scene(SCENES / f"obstacles-{scene}.json")
        e = w.scene.entry(m.id)
        qs = e.bound.random_q(np.random.default_rng(5), 150)
        before = w.get_joint_positions(m.id)
        fast = w.collision_free_batch(m.id, qs, bounds=False)
        assert np.array_equal(w.get_joint_positions(m.id), before)
        slow = np.array([w.check_collision(m.id, q).collision_free for q in qs])
        brute = np.array([_brute_force_free(w, m.id, q) for q in qs])
        e.bound.apply(before)
        assert np.array_equal(fast, slow)
        assert np.mean(fast == brute) >= 0.98, np.flatnonzero(fast != brute)
        assert 0.1 < fast.mean() < 0.95


@pytest.mark.parametrize("urdf", ["xarm/xarm6_with_gripper.urdf", PANDA])
def test_a_rows_label_does_not_depend_on_the_row_checked_before_it(urdf: str) -> None:
    """Bullet keeps a pair's contact points from one check to the next and refreshes only their distances:
    after another configuration it may report a contact the pair's own test does not find (the xArm's
    gripper knuckles) or a touching pair apart (the Panda's fingers). A contact point reported within
    ``RECHECK`` of touching is confirmed by the pair's fresh test, so rows labelled in one order, in the
    reverse order (in the mirror world holding the robot alone, and in the main world among obstacles)
    and each alone get the same labels, and the contacts a check of one configuration names say the
    same."""
    with World() as w:
        m = w.load_robot(urdf)
        w.load_scene(SCENES / "obstacles-4.json")
        e = w.scene.entry(m.id)
        qs = e.bound.random_q(np.random.default_rng(26), 3000)
        mirror = w.queries.mirror(m.id)
        forward = mirror.batch(m.id, qs, {}, e.bound.followers)
        assert 0.05 < forward.mean() < 0.95
        assert np.array_equal(mirror.batch(m.id, qs[::-1], {}, e.bound.followers)[::-1], forward)
        main = e.checker.batch(qs[:600])
        assert np.array_equal(e.checker.batch(qs[:600][::-1])[::-1], main)
        for i in range(0, 600, 7):
            assert e.checker.batch(qs[i:i + 1])[0] == main[i], i
        for i in range(600):  # the contacts a single check names (after the row before it) agree
            assert w.check_collision(m.id, qs[i]).collision_free == main[i], i


def test_batch_rejects_bad_arrays() -> None:
    """Wrong shapes, NaN and out-of-limit rows are refused before any check."""
    with World() as w:
        m = w.load_robot(KUKA)
        with pytest.raises(InvalidParams):
            w.collision_free_batch(m.id, np.zeros((4, 6)))
        with pytest.raises(InvalidParams):
            w.collision_free_batch(m.id, [[0.0] * 7, ["x"] * 7])  # type: ignore[arg-type]
        bad = np.zeros((4, 7))
        bad[2, 3] = np.nan
        with pytest.raises(InvalidParams):
            w.collision_free_batch(m.id, bad)
        bad[2, 3] = 9.0
        with pytest.raises(OutOfLimits):
            w.collision_free_batch(m.id, bad)


def test_two_robots_see_each_other() -> None:
    """A second robot is an obstacle for the first, named by its id and link."""
    with World() as w:
        a = w.load_robot(KUKA, robot_id="a")
        w.load_robot(KUKA, robot_id="b", base_position=(0.5, 0, 0))
        rep = w.check_collision(a.id, [0, 1.2, 0, 0, 0, 0, 0])
        assert any(c.b.body == "b" for c in rep.contacts)


def test_fast_batch_with_second_robot_and_mesh_obstacle() -> None:
    """The batch mirror sees other robots (at their current state) and mesh obstacles like check_collision."""
    with World() as w:
        a = w.load_robot(KUKA, robot_id="a")
        w.load_robot(PANDA, robot_id="p", base_position=(0.7, 0, 0))
        w.set_joint_positions("p", [0.5, 0.3, 0, -1.5, 0, 1.8, 0, 0.02])
        w.add_obstacle(
            {
                "name": "cube",
                "shape": {"type": "mesh", "file": str(MODELS / "meshes" / "cube.obj"), "scale": 2.0},
                "position": [-0.5, 0.2, 0.6],
            }
        )
        qs = w.scene.entry(a.id).bound.random_q(np.random.default_rng(9), 150)
        fast = w.collision_free_batch(a.id, qs)
        slow = np.array([w.check_collision(a.id, q).collision_free for q in qs])
        assert np.array_equal(fast, slow)
        hits = {c.b.body for q in qs[~slow] for c in w.check_collision(a.id, q).contacts}
        assert {"p", "cube"} <= hits
        w.set_joint_positions("p", [-0.5, 0.3, 0, -1.5, 0, 1.8, 0, 0.02])  # the mirror follows the new state
        assert np.array_equal(
            w.collision_free_batch(a.id, qs), [w.check_collision(a.id, q).collision_free for q in qs]
        )


def test_ik_reports_when_only_colliding_solutions_exist() -> None:
    """A target inside an obstacle: the solution is returned flagged collisionFree=False."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(
            {"name": "ball", "shape": {"type": "sphere", "radius": 0.12}, "position": [0.5, 0, 0.5]}
        )
        r = w.ik(m.id, (0.5, 0.0, 0.5))
        assert r.position_error <= 1e-3 and not r.collision_free
        assert not w.check_collision(m.id, r.positions).collision_free


def test_other_robot_arm_reaching_the_fixed_base_is_seen_after_it_moves() -> None:
    """Robot b's arm moved onto robot a's base is a contact for a, and gone when b moves away."""
    with World() as w:
        w.load_robot(KUKA, robot_id="a")
        w.load_robot(KUKA, robot_id="b", base_position=(0.75, 0, 0))
        w.set_joint_positions("b", [0, -1.22, 0, 1.32, 0, -0.22, 0])  # flange on a's base
        assert any(c.b.body == "b" and c.a.link == "lbr_iiwa_link_0" for c in w.check_collision("a").contacts)
        assert not w.collision_free_batch("a", np.zeros((1, 7)))[0]
        w.set_joint_positions("b", [0.0] * 7)  # and moved away again: no stale contact
        assert w.check_collision("a").collision_free
        assert w.collision_free_batch("a", np.zeros((1, 7)))[0]
