"""A collision-free joint path around obstacles, for when no straight one exists.

OMPL's RRT-Connect searches the robot's joint space (bounds = joint limits; a state is valid when the
robot keeps the path clearance to everything), and OMPL's path simplifier shortcuts the result. A motion
is checked at OMPL's own spacing (states a fixed fraction of the joint space apart), its end first, then
in bisection order, its states put to the outer bounds in that order (`outerbounds.py`, once loaded:
`planning.warmUp`; in batches as far as the first refusal, `pathcheck.Ahead`) and only those they do not
find free asked of Bullet (a state they find free keeps the clearance). Every segment of its path is then
checked by our own path check (no point of the robot travels more than twice the clearance unchecked,
clearance kept — `pathcheck.first_contact`). A segment ours refuses is replaced by a second search
between its ends (valid states) in which every motion OMPL checks is our path check (`_PathCheck`: slower,
so only there). Throwing such a path away instead made the search depend on luck: one way found a
detour, the way back failed where the reverse of that detour passed.

The shortcut path still turns sharply at its waypoints. `smooth` cuts its corners (Chaikin: each round
replaces every segment by its points at 1/4 and 3/4, converging to a quadratic B-spline through the
same region; start and goal stay) for up to `SMOOTH_ROUNDS` rounds, keeping the last round whose
segments all pass our path check: each round about halves the turn at every corner (a 90 degree corner
becomes about 8 turns of 11 degrees after 3 rounds).

A detour found is remembered (`DetourMemory`, per robot, for the world version it was found in): a
request between two of its states, in either direction (above all the move back from its end to its
start), takes that stretch of it again once it passes our path check again, instead of a new random
search that may find nothing where a way is known to exist.
"""

from __future__ import annotations

import functools
import itertools
import time
from collections.abc import Callable, Iterable

import numpy as np
from ompl import base as ob
from ompl import geometric as og
from ompl import util as ou

from robwot_sim.sim.collision import CollisionChecker
from robwot_sim.sim.pathcheck import Ahead, first_contact, path_clearance
from robwot_sim.sim.planning_scene import JointVector, Scene
from robwot_sim.sim.robot import LIMIT_TOL, BoundRobot
from robwot_sim.sim.sweep import Guard, substeps
from robwot_sim.sim.types import FloatArray
from robwot_sim.sim.world_thread import checkpoint

#: seconds a detour search (planning and shortcutting) may take
BUDGET = 2.0

#: OMPL's own check spacing along a motion, as a fraction of the joint space's extent (its default is
#: 0.01: ~0.1 rad on a 7-joint arm, too coarse to find gaps our check accepts)
RESOLUTION = 0.002
#: the spacing of the quick look at a motion before our path check (`find_detour`), in path-check steps
COARSE = 8
#: corner-cutting rounds of a detour (each doubles the waypoints)
SMOOTH_ROUNDS = 3
#: OMPL's random seed (the process's first search)
SEED = 26
#: seconds of search after which a motion check gives up Python's lock once (to the backend's loop), at most
#: (giving it up costs a system call, as much as checking a short motion)
YIELD_EVERY = 0.002
#: detours remembered per robot (the most recent ones)
REMEMBERED = 4
#: how close (rad or m, per joint) a request's state must be to a remembered detour's to reuse it
SAME_STATE = 1e-6

ou.setLogLevel(ou.LOG_WARN)
# OMPL takes its seed only before its first random number: once per process. Its searches are therefore
# not reproducible per request; the same request again reuses the detour found (`DetourMemory`).
ou.RNG.setSeed(SEED)


def find_detour(robot: BoundRobot, checker: CollisionChecker, start: FloatArray, goal: FloatArray,
                guard: Guard, clearance: float, budget: float = BUDGET) -> list[FloatArray] | None:
    """Waypoints from ``start`` (excluded) to ``goal`` (included) whose segments all pass our path
    check, or None when none was found within ``budget`` seconds. Moves the robot: the caller restores
    its state."""
    deadline = time.monotonic() + budget
    path = _search(robot, checker, start, goal, guard, clearance, deadline, exact=False)
    if path is None:
        return None
    joined = [path[0]]
    for a, b in itertools.pairwise(path):
        if first_contact(robot, checker, a, b, guard, clearance) is not None:
            # OMPL's spaced states passed where ours do not: join the two (valid) ends by a search
            # whose every motion is our path check
            way = _search(robot, checker, a, b, guard, clearance, deadline, exact=True)
            # other robots may have moved at a checkpoint during the search: checked once more
            if way is None or not _passes(robot, checker, way, guard, clearance):
                return None
            joined += way[1:-1]
        joined.append(b)
    return smooth(robot, checker, joined, guard, clearance, SMOOTH_ROUNDS)[1:]


def _search(robot: BoundRobot, checker: CollisionChecker, start: FloatArray, goal: FloatArray,
            guard: Guard, clearance: float, deadline: float, exact: bool) -> list[FloatArray] | None:
    """OMPL's path from ``start`` to ``goal`` (both included), shortcut, or None by ``deadline``. Its
    motions are checked at states `RESOLUTION` apart, or with ``exact`` by our path check."""
    dof = len(start)
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for i in range(dof):  # a pinned joint (a gripper's) as a sliver: OMPL needs low < high
        pinned = robot.pinned.get(i)
        bounds.setLow(i, float(robot.lower[i]) if pinned is None else pinned - LIMIT_TOL)
        bounds.setHigh(i, float(robot.upper[i]) if pinned is None else pinned + LIMIT_TOL)
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)

    def valid(state: ob.State) -> bool:
        checkpoint()  # raising Cancelled here unwinds through OMPL's solve: the setup is not reused
        robot.apply(_vector(state, dof))
        return checker.is_free(clearance)

    def motion(a: FloatArray, b: FloatArray) -> bool:
        # most motions a search tries are refused: a few states spread over the motion in bisection order
        # find most refusals before the dense walk from its start (which alone decides an acceptance)
        n = substeps(a, b, guard.reach, COARSE * guard.max_sweep)
        for k in _bisection(n)[1:]:
            robot.apply(a + (b - a) * (k / n))
            if not checker.is_free(clearance):
                return False
        return first_contact(robot, checker, a, b, guard, clearance) is None

    def spaced(a: FloatArray, b: FloatArray) -> bool:
        # OMPL's own motion check (its states `RESOLUTION` of the extent apart, the end first, then in
        # bisection order), the states the outer bounds find free asked of Bullet no more (tested in that
        # order as far as the first refusal, as a path check's walk does)
        checkpoint()
        n = max(1, int(np.ceil(float(np.linalg.norm(b - a)) / spacing)))
        order = _bisection(n)
        ahead = Ahead(checker, a + (b - a) * (order / n)[:, None], clearance)
        k = ahead.unsure(0)
        while k < n:
            robot.apply(ahead.states[k])
            if not checker.is_free(clearance):
                return False
            k = ahead.unsure(k + 1)
        return True

    setup.setStateValidityChecker(valid)
    info = setup.getSpaceInformation()
    info.setStateValidityCheckingResolution(RESOLUTION)
    spacing = RESOLUTION * space.getMaximumExtent()
    validator = _PathCheck(info, motion if exact else spaced, dof)  # referenced until the search ends
    info.setMotionValidator(validator)
    setup.setPlanner(og.RRTConnect(info))
    begin, end = _state(space, start), _state(space, goal)
    setup.setStartAndGoalStates(begin, end)
    left = deadline - time.monotonic()
    if left <= 0 or not setup.solve(left) or not setup.haveExactSolutionPath():
        return None
    setup.simplifySolution(max(0.05, deadline - time.monotonic()))
    path = [_vector(s, dof) for s in setup.getSolutionPath().getStates()]
    path[0], path[-1] = start.copy(), goal.copy()
    return path


class _PathCheck(ob.MotionValidator):  # type: ignore[misc]
    """OMPL's motion check made ours: OMPL's spacing with the outer bounds first, or, for the second
    search between the ends of a refused segment, our path check (`pathcheck.first_contact`): a motion
    that search or its shortcuts take passes it, so a path found is a path we accept."""

    def __init__(self, info: ob.SpaceInformation, motion: Callable[[FloatArray, FloatArray], bool],
                 dof: int) -> None:
        super().__init__(info)
        self._motion, self._dof = motion, dof
        self._yielded = time.monotonic()

    def checkMotion(self, a: ob.State, b: ob.State, *_: object) -> bool:
        # called from OMPL's C++ loop, a Python validator takes Python's lock back before a waiting thread
        # gets it (the backend's loop answered pings after up to a second): it is given up at the first
        # motion check after every YIELD_EVERY of search
        now = time.monotonic()
        if now - self._yielded >= YIELD_EVERY:
            time.sleep(0)
            self._yielded = now
        return self._motion(_vector(a, self._dof), _vector(b, self._dof))


@functools.lru_cache(maxsize=256)
def _bisection(n: int) -> FloatArray:
    """The steps 1..n of a motion in n steps, the end first, then 1..n-1 in bisection order (n/2, then the
    quarters, ...) (read only: cached)."""
    out: list[int] = [n]
    seen = {0, n}
    width = n
    while width > 1:
        for k in range(width // 2, n, width):
            if k not in seen:
                seen.add(k)
                out.append(k)
        width = (width + 1) // 2
    out += [k for k in range(1, n) if k not in seen]
    steps = np.array(out, dtype=np.float64)
    steps.flags.writeable = False
    return steps


def _vector(state: ob.State, dof: int) -> FloatArray:
    return np.array([state[i] for i in range(dof)], dtype=np.float64)


class DetourMemory:
    """The last `REMEMBERED` detours of each robot of a scene, found in its current version (a change of
    the scene makes the older ones useless: they are dropped at the next one remembered)."""

    def __init__(self) -> None:
        self._paths: dict[str, list[tuple[int, list[FloatArray]]]] = {}

    def remember(self, robot_id: str, version: int, path: list[FloatArray]) -> None:
        """``path``: start and goal included."""
        self._paths = {rid: [(v, p) for v, p in paths if v == version]
                       for rid, paths in self._paths.items()}
        kept = self._paths.get(robot_id, [])[-(REMEMBERED - 1):]
        self._paths[robot_id] = [*kept, (version, path)]

    def stretches(self, robot_id: str, version: int, start: FloatArray,
                  goal: FloatArray) -> list[list[FloatArray]]:
        """The stretches of the robot's remembered detours (newest first) from a state at ``start`` to a
        later or earlier state at ``goal``, in the order they were found (a move back: reversed), their
        ends replaced by the given states."""
        out = []
        for v, path in reversed(self._paths.get(robot_id, [])):
            if v != version:
                continue
            i, j = _index(path, start), _index(path, goal)
            if i is None or j is None or i == j:
                continue
            lo, hi = min(i, j), max(i, j)
            first, last = (start, goal) if i < j else (goal, start)
            out.append([first.copy(), *path[lo + 1:hi], last.copy()])
        return out


def _index(path: list[FloatArray], q: FloatArray) -> int | None:
    for k, p in enumerate(path):
        if float(np.max(np.abs(p - q))) <= SAME_STATE:
            return k
    return None


def recall(robot: BoundRobot, checker: CollisionChecker, stretches: list[list[FloatArray]],
           start: FloatArray, guard: Guard, clearance: float) -> list[FloatArray] | None:
    """Waypoints like `find_detour`'s along one of the remembered ``stretches``
    (`DetourMemory.stretches`) that passes our path check now, or None. A stretch is checked in the order
    it was found: a move back asks our path check the very states the search's check asked. Moves the
    robot: the caller restores it."""
    for path in stretches:
        if _passes(robot, checker, path, guard, clearance):
            forward = np.array_equal(path[0], start)
            return path[1:] if forward else path[::-1][1:]
    return None


def detour(scene: Scene, robot_id: str, target: JointVector, memory: DetourMemory,
           budget: float = BUDGET) -> list[tuple[float, ...]] | None:
    """Waypoints (ending at ``target``) of a collision-free path of a robot of ``scene`` from its current
    state around what blocks the straight one, or None; the scene unchanged. A stretch of a detour found
    before in this version of the scene (either way along it: ``memory``) is taken again when it still
    passes the path check; else RRT-Connect searches one (`find_detour`), remembered when found."""
    e = scene.entry(robot_id)
    tgt = e.bound.validate(target, "target")
    saved = e.bound.q.copy()
    version = scene.version
    try:
        clearance = path_clearance(e.bound, e.checker, saved, e.guard, tgt)
        with scene.holding(robot_id):
            stretches = memory.stretches(robot_id, version, saved, tgt)
            found = recall(e.bound, e.checker, stretches, saved, e.guard, clearance)
            if found is None:
                found = find_detour(e.bound, e.checker, saved, tgt, e.guard, clearance, budget)
                if found is not None:
                    memory.remember(robot_id, version, [saved, *found])
    finally:
        e.bound.apply(saved)
    return None if found is None else [tuple(float(x) for x in w) for w in found]


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
