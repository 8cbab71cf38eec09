"""Trajectory timing (MoveIt's trajectory processing): the timed path a valid plan's move runs.

A plan whose straight path was checked carries that timed path (``Plan.path``): a move at the same
timing runs it, not a path planned again. Otherwise (a detour, a LIN or CIRC, another acceleration) the
path is timed here from the plan's waypoints; the states of a LIN or CIRC between its checked samples are
checked once more, so every state a motion runs was checked in this world.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robwot_sim.sim.planner import Plan, contact_words, path_check
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.world import World


def timed_path(world: World, robot: str, plan: Plan, *, speed: float, dt: float, acceleration: float = 1.0,
               start: Sequence[float] | None = None) -> tuple[Plan, TimedPath | None]:
    """The timed path, states one per ``dt``, that a move of the valid ``plan`` runs
    (``World.plan_motion``), with the plan; None for a refused plan. The states of a LIN or CIRC lie on the
    spline through its checked samples, not on the chords between them: they are checked again, and a
    contact refuses the plan (naming the bodies), so every state a motion runs was checked in this world."""
    if not plan.valid or plan.target is None:
        return plan, None
    if _checked_path_fits(plan, speed, dt, acceleration, start):
        assert plan.path is not None
        return plan, plan.path  # the path the plan checked: not planned again
    path = world.plan_motion(robot, plan.target, start, speed, dt, acceleration=acceleration,
                             **plan.motion_kwargs())
    if not plan.arc:
        return plan, path
    report = world.check_states(robot, path)
    if report.collision_free or report.first_collision is None:
        return plan, path
    contacts = report.first_collision.contacts
    kind = str(plan.checks.get("path", {}).get("planned", "lin"))
    reason = (f"{kind.upper()} refused: the timed path between its checked samples collides"
              f"{contact_words(contacts)}")
    checks = {**plan.checks, "path": path_check(world.robot_model(robot).clearance, False, contacts, kind)}
    return Plan(False, None, (reason,), checks), None


def _checked_path_fits(plan: Plan, speed: float, dt: float, acceleration: float,
                       start: Sequence[float] | None) -> bool:
    """Whether the path the plan checked is the one a move from ``start`` (None: where the plan was made)
    at this timing runs: timed alike (the check runs at the full acceleration limits), from the same
    state."""
    if plan.path is None or plan.timing != (speed, dt) or acceleration != 1.0:
        return False
    return start is None or bool(np.array_equal(plan.path.first, np.asarray(start, dtype=np.float64)))
