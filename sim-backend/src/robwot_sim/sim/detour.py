"""A collision-free joint path around obstacles, for when no straight one exists.

OMPL's RRT-Connect searches the robot's joint space (bounds = joint limits; a state is valid when the
robot keeps the path clearance to everything), and OMPL's path simplifier shortcuts the result. OMPL
only proposes: every segment of the final path is then checked by our own path check (no point of the
robot travels more than twice the clearance unchecked, clearance kept — `pathcheck.first_contact`), and
a path that fails it is not used. The search is seeded, so the same request gets the same path.

The shortcut path still turns sharply at its waypoints. `smooth` cuts its corners (Chaikin: each round
replaces every segment by its points at 1/4 and 3/4, converging to a quadratic B-spline through the
same region; start and goal stay) for up to `SMOOTH_ROUNDS` rounds, keeping the last round whose
segments all pass our path check: each round about halves the turn at every corner (a 90 degree corner
becomes about 8 turns of 11 degrees after 3 rounds).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Iterable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from robwot_sim.sim.collision import CollisionChecker
from robwot_sim.sim.pathcheck import Guard, first_contact
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import FloatArray
from robwot_sim.sim.world_thread import checkpoint

#: seconds a detour search (planning and shortcutting) may take
BUDGET = 2.0
#: OMPL's own check spacing along a motion, as a fraction of the joint space's extent (its default is
#: 0.01: ~0.1 rad on a 7-joint arm, too coarse to find gaps our check accepts)
RESOLUTION = 0.002

#: corner-cutting rounds of a detour (each doubles the waypoints)
SMOOTH_ROUNDS = 3

ou.setLogLevel(ou.LOG_WARN)


def find_detour(robot: BoundRobot, checker: CollisionChecker, start: FloatArray, goal: FloatArray,
                guard: Guard, clearance: float, seed: int,
                budget: float = BUDGET) -> list[FloatArray] | None:
    """Waypoints from ``start`` (excluded) to ``goal`` (included) whose segments all pass our path
    check, or None when none was found within ``budget`` seconds. Moves the robot: the caller restores
    its state."""
    dof = len(start)
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for i in range(dof):
        bounds.setLow(i, float(robot.lower[i]))
        bounds.setHigh(i, float(robot.upper[i]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)

    def valid(state: ob.State) -> bool:
        checkpoint()  # raising Cancelled here unwinds through OMPL's solve: the setup is not reused
        robot.apply(np.array([state[i] for i in range(dof)], dtype=np.float64))
        return checker.is_free(clearance)

    setup.setStateValidityChecker(valid)
    info = setup.getSpaceInformation()
    info.setStateValidityCheckingResolution(RESOLUTION)
    setup.setPlanner(og.RRTConnect(info))
    begin, end = _state(space, start), _state(space, goal)
    setup.setStartAndGoalStates(begin, end)
    ou.RNG.setSeed(seed)
    t0 = time.monotonic()
    if not setup.solve(budget) or not setup.haveExactSolutionPath():
        return None
    setup.simplifySolution(max(0.05, budget - (time.monotonic() - t0)))
    states = setup.getSolutionPath().getStates()
    path = [np.array([s[i] for i in range(dof)], dtype=np.float64) for s in states]
    path[0], path[-1] = start.copy(), goal.copy()
    if not _passes(robot, checker, path, guard, clearance):
        return None
    return smooth(robot, checker, path, guard, clearance, SMOOTH_ROUNDS)[1:]


def smooth(robot: BoundRobot, checker: CollisionChecker, path: list[FloatArray], guard: Guard,
           clearance: float, rounds: int = SMOOTH_ROUNDS) -> list[FloatArray]:
    """``path`` (start and goal included) with its corners cut (module docstring), as far as our path
    check lets it: the last round whose segments all pass. Moves the robot: the caller restores it."""
    best = path
    for _ in range(rounds if len(path) > 2 else 0):
        cut = [best[0]]
        for a, b in itertools.pairwise(best):
            cut += [0.75 * a + 0.25 * b, 0.25 * a + 0.75 * b]
        cut.append(best[-1])
        if not _passes(robot, checker, cut, guard, clearance):
            break
        best = cut
    return best


def _passes(robot: BoundRobot, checker: CollisionChecker, path: list[FloatArray], guard: Guard,
            clearance: float) -> bool:
    return all(first_contact(robot, checker, a, b, guard, clearance) is None
               for a, b in itertools.pairwise(path))


def _state(space: ob.RealVectorStateSpace, q: Iterable[float]) -> ob.State:
    state = space.allocState()
    for i, v in enumerate(q):
        state[i] = float(v)
    return state
