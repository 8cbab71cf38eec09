"""Jerk limits (``motion.py``: a joint_limits.yaml's ``max_jerk``, robot.load ``jerkLimits``): every motion
of a robot with them keeps each limited joint's jerk within its limit, measured by third differences of its
states at 1/240 s, with its velocity and acceleration still within theirs and its geometry unchanged."""

from __future__ import annotations

import numpy as np
import pytest
from simhelp import KUKA, steps_of

from robwot_sim.errors import InvalidParams
from robwot_sim.sim.planner import plan_lin
from robwot_sim.sim.program import plan_program
from robwot_sim.sim.timed import Curve, Straight, TimedPath
from robwot_sim.sim.world import World

DT = 1 / 240
START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]
JERK = 100.0  # rad/s^3, every joint (the KUKA's acceleration limits are 40 rad/s^2)


def _rates(path: TimedPath) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    q = path.rows()
    return tuple(np.abs(np.diff(q, k, axis=0)).max(axis=0) / DT**k for k in (1, 2, 3))  # type: ignore[return-value]


def _kuka(w: World, jerk: float | None) -> str:
    files = World.read_robot(KUKA)
    names = [j.name for j in files.urdf_model.joints if j.type != "fixed"]
    return w.add_robot(files, jerks={n: jerk for n in names} if jerk else None).id


def test_a_joint_move_keeps_the_jerk_limit_and_takes_the_s_curves_time() -> None:
    """PTP at 30 % speed (it cruises): jerk within the limit, velocity and acceleration within theirs;
    its time the trapezoid's plus A / J (the time-optimal jerk-limited profile of a line that reaches its
    velocity and acceleration limits), the states on the same line, ending at the target. A jerk limit so
    low that A / J would be long (a short move) lowers the acceleration instead: far less than the
    trapezoid plus 2 A / J."""
    jerk_limit = 4 * JERK
    with World() as w, World() as w2:
        free, limited = _kuka(w, None), _kuka(w2, jerk_limit)
        model = w2.robot_model(limited)
        target = [2.0, 0.2, 0.0, -0.8, 0.0, 0.4, 0.0]
        a = w.plan_motion(free, target, START, speed=0.3, dt=DT)
        b = w2.plan_motion(limited, target, START, speed=0.3, dt=DT)
        piece = b.pieces[0]
        assert isinstance(piece, Straight) and piece.window > 0
        v, acc, jerk = _rates(b)
        jerk0 = _rates(a)[2]
        assert jerk0.max() > 5 * jerk_limit  # the unlimited motion's jerk: the limit binds
        assert jerk.max() <= jerk_limit * 1.02
        assert np.all(v <= 0.3 * model.velocity_limits() * 1.001)
        assert np.all(acc <= model.acceleration_limits() * 1.01)
        delta = np.abs(np.asarray(target) - np.asarray(START))
        assert b.duration == pytest.approx(a.duration + 40.0 / jerk_limit, abs=2 * DT)
        rows = b.rows()
        along = (rows - np.asarray(START)) @ (np.asarray(target) - np.asarray(START))
        off = rows - np.asarray(START) - np.outer(along / (delta @ delta), np.asarray(target) - START)
        assert np.abs(off).max() < 1e-9 and rows[-1] == pytest.approx(target)
        low = _kuka(w2, 20.0)
        short = w2.plan_motion(low, target, START, dt=DT)
        assert _rates(short)[2].max() <= 20.0 * 1.02
        whole = w.plan_motion(free, target, START, dt=DT).duration
        # the fraction of the 2 rad line: A = 40 / 2, J = 20 / 2 per s^2 and s^3; a triangle (no cruise) at A
        # would take its window 2 A / J longer
        assert short.duration < 0.5 * (whole + 2 * (40.0 / 2) / (20.0 / 2))


def test_a_lin_keeps_the_jerk_limit_on_its_line() -> None:
    """LIN (a TOPP-RA curve): jerk within the limit, velocity and acceleration within theirs, the same
    waypoints as without jerk limits and a longer time."""
    with World() as w, World() as w2:
        free, limited = _kuka(w, None), _kuka(w2, JERK)
        model = w2.robot_model(limited)
        plans = []
        for world, rid in ((w, free), (w2, limited)):
            world.set_joint_positions(rid, START)
            x, y, z = world.fk(rid).position
            plans.append(plan_lin(world, rid, (x, y + 0.2, z - 0.1), None, dt=DT, tcp_speed=0.5))
        a, b = plans
        assert a.valid and b.valid and a.path is not None and b.path is not None
        assert np.allclose(np.asarray(b.via), np.asarray(a.via))  # the same waypoints
        piece = b.path.pieces[0]
        assert isinstance(piece, Curve) and piece.window > 0
        v, acc, jerk = _rates(b.path)
        assert _rates(a.path)[2].max() > 2 * JERK
        assert jerk.max() <= JERK * 1.05
        assert np.all(v <= model.velocity_limits() * 1.02)
        assert np.all(acc <= model.acceleration_limits() * 1.05)
        assert b.path.duration > a.path.duration


def test_a_blended_corner_keeps_the_jerk_limit() -> None:
    """Two LINs blended through a right angle (a tight joint-space curve, where the path's curvature, not
    the profile's window, makes the jerk): within the limit by third differences of every state."""
    with World() as w:
        rid = _kuka(w, JERK)
        w.set_joint_positions(rid, START)
        x, y, z = w.fk(rid).position
        steps = steps_of([{"motion": "lin", "position": [x, y + 0.1, z], "tcpSpeed": 0.5, "blend": 0.02},
                          {"motion": "lin", "position": [x - 0.1, y + 0.1, z], "tcpSpeed": 0.5}], 7)
        plan = plan_program(w, rid, steps, DT, 1 / DT)
        assert plan.path is not None, plan.report["steps"]
        assert _rates(plan.path)[2].max() <= JERK * 1.05


def test_jerk_limits_of_joints_the_robot_lacks_or_not_positive_are_refused() -> None:
    with World() as w:
        for bad in ({"nope": 1.0}, {"lbr_iiwa_joint_1": 0.0}):
            with pytest.raises(InvalidParams) as refused:
                w.add_robot(World.read_robot(KUKA), jerks=bad)
            assert refused.value.data["param"] == "jerkLimits"
        assert w.robot_ids() == []
