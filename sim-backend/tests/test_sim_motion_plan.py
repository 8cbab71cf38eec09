"""Joint-space motion planning and path checking (H1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simhelp import KUKA, MODELS

from robwot_sim.errors import InvalidParams, OutOfLimits
from robwot_sim.sim.world import World


def test_plan_respects_velocity_and_acceleration_limits_and_dt() -> None:
    """Steps are dt apart; no joint moves faster than velocity * speed nor accelerates faster than its
    acceleration limit (velocity / 0.25 s without a joint_limits.yaml); the duration is the trapezoid's,
    time-optimal for the straight line, rounded up to whole steps; start and target included."""
    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")  # velocities 1.5 and 3.0 rad/s
        accel = m.acceleration_limits()
        assert accel.tolist() == pytest.approx([6.0, 12.0])
        for speed, dt, duration in [(1.0, 1 / 240, 1.0 + 0.25), (0.25, 0.01, 4.0 + 0.0625),
                                    (1.0, 0.01, 2 * math.sqrt(0.1 / 4))]:
            goal = [1.5, -2.0] if duration > 0.5 else [0.15, -0.2]  # the last: too short to reach vmax
            path = w.plan_motion(m.id, goal, start=[0.0, 0.0], speed=speed, dt=dt).rows()
            assert np.allclose(path[0], [0, 0]) and np.allclose(path[-1], goal)
            vel = np.diff(path, axis=0) / dt
            assert np.all(np.abs(vel) <= np.array([1.5, 3.0]) * speed * (1 + 1e-9))
            # a finite difference of positions sampled from the profile: within the limit up to the
            # sampling of its kinks
            acc = np.abs(np.diff(vel, axis=0)) / dt
            assert np.all(acc <= accel * 1.01 + 1e-6), acc.max(axis=0)
            assert (len(path) - 1) * dt == pytest.approx(duration, abs=dt)
        assert len(w.plan_motion(m.id, [0.0, 0.0], start=[0.0, 0.0])) == 1


def test_a_curve_is_timed_along_its_samples_within_every_limit() -> None:
    """A LIN's samples (a joint-space arc here) timed by TOPP-RA: it starts and ends at rest at the first and
    last sample, passes within a hair of every sample, keeps the joint velocity and acceleration limits
    and the end effector's speed along the curve, and is no slower than needed: some limit is met."""
    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")
        t = np.linspace(0.0, 1.0, 41)
        points = np.stack([0.8 * t, -0.6 * np.sin(math.pi * t)], axis=1)
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))]) * 0.5
        dt = 0.005
        path = w.plan_motion(m.id, points[-1], start=points[0], dt=dt, via=points[1:-1], arc=arc,
                             tcp_speed=0.3).rows()
        assert np.allclose(path[0], points[0]) and np.allclose(path[-1], points[-1])
        vel = np.diff(path, axis=0) / dt
        assert np.all(np.abs(vel) <= np.array([1.5, 3.0]) * 1.01)
        # the end effector's speed along the curve: arc length is half the joint-space length here
        speed = np.linalg.norm(vel, axis=1) * 0.5
        assert speed.max() <= 0.3 * 1.02 and speed.max() >= 0.3 * 0.9
        nearest = np.min(np.linalg.norm(path[:, None, :] - points[None, :, :], axis=2), axis=0)
        assert nearest.max() < 0.01


def test_plan_rejects_out_of_limit_targets() -> None:
    """A target beyond the joint limits is refused (speed and dt ranges are the contract's: checked where a
    request enters)."""
    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")
        with pytest.raises(OutOfLimits):
            w.plan_motion(m.id, [0.1, 3.0])


def test_check_path_finds_first_collision_without_state_change() -> None:
    """Sweeping joint 1 through a post reports the first colliding state and pair; state is unchanged."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, [-1.5, 1.0, 0, 0, 0, 0, 0])
        w.add_obstacle(
            {
                "name": "post",
                "shape": {"type": "cylinder", "radius": 0.05, "length": 1.0},
                "position": [0.6, 0.0, 0.5],
            }
        )
        before = w.get_joint_positions(m.id)
        rep = w.check_path(m.id, [1.5, 1.0, 0, 0, 0, 0, 0], speed=0.5)
        assert not rep.collision_free and rep.first_collision is not None
        fc = rep.first_collision
        assert 0 < fc.time < rep.duration
        assert -0.6 < fc.positions[0] < 0.2
        assert any(c.b.body == "post" for c in fc.contacts)
        assert np.array_equal(w.get_joint_positions(m.id), before)
        free = w.check_path(m.id, [-1.0, 1.0, 0, 0, 0, 0, 0])
        assert free.collision_free and free.first_collision is None
        assert free.to_json()["steps"] == free.steps
        # the first contact's time is that of the timed path's state it names (the path accelerates)
        path = w.plan_motion(m.id, [1.5, 1.0, 0, 0, 0, 0, 0], speed=0.5)
        k = fc.time / (rep.duration / (rep.steps - 1))
        row = path[int(k)] + (k - int(k)) * (path[min(int(k) + 1, len(path) - 1)] - path[int(k)])
        assert np.abs(row - np.array(fc.positions)).max() < 1e-6


def test_a_timed_straight_path_is_one_segment_and_a_turn_makes_a_vertex() -> None:
    """A straight joint motion is one straight piece, checked as one segment however it accelerates along
    it (each segment starts with a distance query); a path through a waypoint has its turn there; a polyline
    of states has its vertices where the direction turns."""
    from robwot_sim.sim.pathcheck import _vertices
    from robwot_sim.sim.timed import Straight

    with World() as w:
        m = w.load_robot(KUKA)
        straight = w.plan_motion(m.id, [1.0, 0.5, 0, -0.5, 0, 0, 0])
        assert len(straight) > 20 and [type(p) for p in straight.pieces] == [Straight]
        rows = straight.rows()
        assert _vertices(rows) == [0, len(rows) - 1]
        bent = w.plan_motion(m.id, [1.0, 0.5, 0, 0, 0, 0, 0], via=[[0.5, 0, 0, 0, 0, 0, 0]])
        rows = bent.rows()
        turn = int(np.flatnonzero(np.all(rows == [0.5, 0, 0, 0, 0, 0, 0], axis=1))[0])
        assert [offset for offset, _ in bent.offsets()] == [0, turn]
        assert _vertices(rows) == [0, turn, len(rows) - 1]


def test_a_pose_beyond_reach_is_refused_naming_the_distance() -> None:
    """2 m above the KUKA (reach 0.901 m from its shoulder at 0.36 m): refused in words with the distance
    beyond the reach sphere; a reachable pose is still planned."""
    from robwot_sim.sim.planner import plan_pose

    with World() as w:
        m = w.load_robot(KUKA)
        far = plan_pose(w, m.id, (0.0, 0.0, 2.0), None, 1.0, 1 / 240)
        assert not far.valid and far.target is None
        assert far.reasons == ("target (0.0000, 0.0000, 2.0000) m is 0.7390 m beyond the robot's reach",)
        error = pytest.approx(0.739, abs=1e-5)
        assert far.checks["ik"] == {"ok": False, "positionError": error, "solutions": 1}
        assert plan_pose(w, m.id, (0.4, 0.1, 0.6), None, 1.0, 1 / 240).valid


def test_a_reachable_pose_inside_an_obstacle_is_refused_naming_what_it_touches() -> None:
    """IK reaches a target inside a block (the position is reached, within tolerance), so the refusal says
    the solutions collide at the target and names the block, not that IK found nothing within 0.001 m
    (which read as a contradiction beside an error of 1e-8 m)."""
    from robwot_sim.sim.planner import plan_pose

    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle({"name": "block", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]},
                        "position": [0.45, 0.1, 0.55]})
        plan = plan_pose(w, m.id, (0.45, 0.1, 0.55), None, 1.0, 1 / 240)
        assert not plan.valid and len(plan.reasons) == 1
        reason = plan.reasons[0]
        assert reason.startswith("every IK solution reaching (0.4500, 0.1000, 0.5500) m")
        assert "collides at the target (" in reason and "block" in reason
        assert "0.001 m" not in reason
        # the path check names what touches at the target, and says no detour was searched
        path = plan.checks["path"]
        assert path["ok"] is False and path["detour"] == "not searched"
        assert any("block" in (c["a"]["body"], c["b"]["body"]) for c in path["contacts"])


def test_a_refused_joint_target_says_whether_a_detour_was_searched_and_why_none_was_found() -> None:
    """A pillar in the one way the shoulder can turn (its limits do not wrap): the straight path collides,
    the detour search finds nothing and the refusal says both, naming the pillar; a target inside the
    pillar is refused as colliding itself, with no search."""
    from robwot_sim.sim.planner import plan_joints

    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")
        w.set_joint_positions(m.id, [-1.5, 0.0])
        w.add_obstacle({"name": "pillar", "shape": {"type": "box", "size": [0.05, 0.3, 0.05]},
                        "position": [0.0, 0.0, 0.35]})
        plan = plan_joints(w, m.id, [1.5, 0.0], 1.0, 1 / 240)
        assert not plan.valid and plan.checks["path"]["detour"] == "not found"
        assert plan.reasons[0].startswith("the straight path to the target collides (")
        assert "pillar" in plan.reasons[0]
        assert "no detour around it found within 2 s (RRT-Connect)" in plan.reasons[0]
        plan = plan_joints(w, m.id, [0.0, 0.0], 1.0, 1 / 240)
        assert not plan.valid and plan.checks["path"]["detour"] == "not searched"
        assert plan.reasons[0].startswith("the target configuration itself collides (")
        assert "pillar" in plan.reasons[0] and plan.reasons[0].endswith(": no path reaches it")


def test_acceleration_limits_given_at_load_replace_the_default_and_are_checked() -> None:
    """A joint_limits.yaml's accelerations (robot.load accelerationLimits) time the motion; a joint that
    is not the robot's, or a value that is not a positive number, is refused and nothing is loaded."""
    with World() as w:
        files = World.read_robot(MODELS / "planar2.urdf")
        m = w.add_robot(files, accelerations={"shoulder": 1.5})
        assert m.acceleration_limits().tolist() == pytest.approx([1.5, 12.0])
        path = w.plan_motion(m.id, [1.5, 0.0], start=[0.0, 0.0], dt=0.01)
        # 1.5 rad: v 1.5 rad/s is never reached at 1.5 rad/s^2 (needs 1.5 rad to reach it): a triangle
        assert (len(path) - 1) * 0.01 == pytest.approx(2 * math.sqrt(1.5 / 1.5), abs=0.01)
        for bad in ({"nope": 1.0}, {"shoulder": 0.0}, {"shoulder": float("inf")}):
            with pytest.raises(InvalidParams):
                w.add_robot(World.read_robot(MODELS / "planar2.urdf"), robot_id="other", accelerations=bad)
            assert w.robot_ids() == [m.id]


def test_curves_under_the_same_limits_share_toppras_constraints(monkeypatch: pytest.MonkeyPatch) -> None:
    """toppra's constraints (whose constructors write their limits out as text) are made once per limits:
    a second curve under the same limits makes none and is timed exactly as with constraints made anew."""
    import toppra.constraint

    from robwot_sim.sim import motion

    made: list[object] = []
    velocity = toppra.constraint.JointVelocityConstraint
    monkeypatch.setattr(toppra.constraint, "JointVelocityConstraint",
                        lambda *a, **k: made.append(a) or velocity(*a, **k))
    motion._fixed_constraints.cache_clear()
    t = np.linspace(0.0, 1.0, 25)[:, None]

    def curve(scale: float) -> np.ndarray:  # a detour's kind of curve: joint limits only
        points = np.hstack([scale * t, -0.6 * np.sin(math.pi * t)])
        return w.plan_motion(m.id, points[-1], start=points[0], via=points[1:-1], arc=[0.0] * len(points),
                             tcp_speed=None).rows()

    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")
        curve(0.8)
        again = curve(0.9)
        assert len(made) == 1
        motion._fixed_constraints.cache_clear()
        assert np.array_equal(curve(0.9), again) and len(made) == 2
