"""Checking a planned joint path for collision at every step, without changing the world."""

from __future__ import annotations

from robwot_sim.sim.collision import CollisionChecker
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import FirstCollision, FloatArray, PathReport


def check_joint_path(robot: BoundRobot, checker: CollisionChecker, path: FloatArray, dt: float) -> PathReport:
    """Check each state of ``path`` (row k at time k * dt); report the first one in collision."""
    saved = robot.q.copy()
    duration = (len(path) - 1) * dt
    try:
        for k, q in enumerate(path):
            robot.apply(q)
            if not checker.is_free():
                contacts = tuple(checker.contacts())
                first = FirstCollision(k * dt, tuple(float(x) for x in q), contacts)
                return PathReport(False, duration, len(path), first)
    finally:
        robot.apply(saved)
    return PathReport(True, duration, len(path))
