"""Checking a planned joint path for collision, without changing the world.

Between the planned states (one per ``dt``) the path is subdivided so that no point of the robot travels
more than twice the robot's clearance between two checked states, and other bodies must stay that
clearance away (a `Guard`; 2 mm unless the robot was loaded with another): then no contact can hide
between checked states, at any speed (see ``sweep.py``). A path that starts or ends within the
clearance (e.g. after a motion stopped on contact) is checked for contact only, so the robot can always
move away from such a state and back to it: the verdict on a path never depends on its direction.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from robwot_sim.limits import CLEARANCE as CLEARANCE_RANGE
from robwot_sim.sim.collision import TOUCH, CollisionChecker
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.sweep import CLEARANCE, substeps
from robwot_sim.sim.types import FirstCollision, FloatArray, PathReport
from robwot_sim.sim.world_thread import checkpoint

#: the clearance a robot may be loaded with (m): above 0 for the sweep bound to hold; at most Bullet's
#: contact breaking threshold (2 cm), the farthest distance at which it reports other bodies
MIN_CLEARANCE, MAX_CLEARANCE = CLEARANCE_RANGE.minimum, CLEARANCE_RANGE.maximum
#: how far beyond the clearance (m) a path check measures the distance to other bodies: the travel that
#: needs no further distance query (larger: fewer queries, each asking more bodies and points)
GAP_CAP = 0.05


@dataclass(frozen=True)
class Guard:
    """What a path check of one robot keeps: ``clearance`` (m) to other bodies, no point travelling more
    than twice that between checked states (``reach``: per joint, how far the farthest collision point
    travels per unit of motion, from ``sweep.joint_reach``)."""

    reach: FloatArray
    clearance: float = CLEARANCE

    @property
    def max_sweep(self) -> float:
        return 2.0 * self.clearance


def path_clearance(robot: BoundRobot, checker: CollisionChecker, start: FloatArray, guard: Guard,
                   *ends: FloatArray) -> float:
    """The clearance a path from ``start`` (through or to ``ends``) keeps: the guard's, or contact only
    when one of those states is closer. Both ends count alike, so a path and its reverse keep the same
    clearance (a path keeping the guard's clearance could not end at a state closer than it)."""
    saved = robot.q.copy()
    try:
        for q in (start, *ends):
            robot.apply(q)
            if not checker.is_free(guard.clearance):
                return TOUCH
        return guard.clearance
    finally:
        robot.apply(saved)


def first_contact(robot: BoundRobot, checker: CollisionChecker, q0: FloatArray, q1: FloatArray,
                  guard: Guard, clearance: float) -> tuple[float, FloatArray] | None:
    """The first state between ``q0`` (excluded) and ``q1`` (included) closer than ``clearance`` to
    anything, as (fraction of the segment, state), or None. Leaves the robot at the last state checked.

    Every state is checked for self-contact. The distance to other bodies (which stand still during a
    check) is measured up to ``GAP_CAP`` beyond the clearance and then not again while the robot's travel
    since that measurement (the sweep bound) keeps within the measured gap minus the clearance: no point
    can have come closer than the clearance meanwhile (conservative advancement). The verdict and the
    first contact are the same as measuring at every state; far from obstacles most queries are saved.
    A checkpoint (`world_thread.checkpoint`) before each state may let other robots move: the distance
    is then measured again."""
    n = substeps(q0, q1, guard.reach, guard.max_sweep)
    step = float(np.sum(np.abs(q1 - q0) * guard.reach)) / n
    slack = -1.0  # travel left before the other bodies must be measured again
    for i in range(1, n + 1):
        if checkpoint():  # other bodies may have moved meanwhile: measure them again
            slack = -1.0
        q = q0 + (q1 - q0) * (i / n)
        robot.apply(q)
        slack -= step
        apart = clearance > TOUCH and slack >= 0.0
        if not apart and clearance > TOUCH:
            gap = checker.gap(clearance + GAP_CAP)
            if gap <= clearance:
                return i / n, q
            apart, slack = True, gap - clearance
        if not checker.is_free(clearance, others_apart=apart):
            return i / n, q
    return None


def _vertices(path: FloatArray) -> list[int]:
    """Indices of the rows where a path of straight segments starts, turns or ends: the rows between them
    lie on the segment, so checking the segment (subdivided by travel) covers them, at any speed (a
    timed path's acceleration along a segment makes no vertex: each one cost a distance query)."""
    if len(path) <= 2:
        return list(range(len(path)))
    # a row is a vertex when the direction of motion changes there; the speed along a straight segment
    # may change (a timed path accelerates): rows standing still keep the direction they had
    step = np.diff(path, axis=0)
    length = np.linalg.norm(step, axis=1)
    scale = max(1.0, float(np.max(np.abs(path))))
    moving = length > 1e-12 * scale
    direction = np.zeros_like(step)
    direction[moving] = step[moving] / length[moving, None]
    kept = np.maximum.accumulate(np.where(moving, np.arange(len(step)), -1))
    direction = np.where(kept[:, None] >= 0, direction[np.maximum(kept, 0)], 0.0)
    turn = np.linalg.norm(direction[1:] - direction[:-1], axis=1) > 1e-9
    return [0, *(np.nonzero(turn)[0] + 1).tolist(), len(path) - 1]


def check_joint_path(robot: BoundRobot, checker: CollisionChecker, path: FloatArray, dt: float,
                     guard: Guard) -> PathReport:
    """Check ``path`` (row k at time k * dt, straight segments) and the sweep along it; report the first
    contact. The cost depends on how far the robot travels, not on how slowly (the number of rows)."""
    saved = robot.q.copy()
    duration = (len(path) - 1) * dt
    try:
        clearance = path_clearance(robot, checker, path[0], guard, path[-1])
        robot.apply(path[0])
        if not checker.is_free():
            start = FirstCollision(0.0, tuple(float(x) for x in path[0]), tuple(checker.contacts()))
            return PathReport(False, duration, len(path), start)
        for a, b in itertools.pairwise(_vertices(path)):
            hit = first_contact(robot, checker, path[a], path[b], guard, clearance)
            if hit is not None:
                frac, q = hit
                # the rows between two vertices lie on the segment in order, at any speed: the time is
                # where the hit's distance along it falls among theirs
                along = np.linalg.norm(path[a:b + 1] - path[a], axis=1)
                at = a + float(np.interp(frac * along[-1], along, np.arange(b - a + 1)))
                first = FirstCollision(at * dt, tuple(float(x) for x in np.asarray(q)),
                                       tuple(checker.contacts(clearance)))
                return PathReport(False, duration, len(path), first)
    finally:
        robot.apply(saved)
    return PathReport(True, duration, len(path))
