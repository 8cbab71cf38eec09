"""Checking a planned joint path for collision, without changing the world.

Between the planned states (one per ``dt``) the path is subdivided so that no point of the robot travels
more than twice the robot's clearance between two checked states (a straight piece from its ends, a
curve at points spaced by that travel: the work follows the geometry, not the number of states), and
other bodies must stay that clearance away (a `Guard`: the contract's default clearance unless the robot
was loaded with another):
then no contact can hide between checked states, at any speed (see ``sweep.py``). A path that starts or
ends within the clearance (e.g. after a motion stopped on contact) is checked for contact only, so the
robot can always move away from such a state and back to it: the verdict on a path never depends on its
direction. A path that starts in contact may leave it while the contact recedes (``exit_contact.py``);
the check applies from the first state free of it.

The functions at the end take a robot of a scene (``planning_scene.Scene``): a path, a step or a motion's
clearance checked with the robot held, its state restored.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robwot_sim.limits import DEFAULT_DT, DEFAULT_SPEED
from robwot_sim.sim.collision import TOUCH, CollisionChecker
from robwot_sim.sim.exit_contact import leave_contact
from robwot_sim.sim.planning_scene import JointVector, Scene
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.sweep import Guard, substeps
from robwot_sim.sim.timed import Curve, Piece, Straight, TimedPath
from robwot_sim.sim.trajectory import plan_motion
from robwot_sim.sim.types import CollisionReport, Contact, FirstCollision, FloatArray, PathReport
from robwot_sim.sim.world_thread import checkpoint

#: how far beyond the clearance (m) a path check measures the distance to other bodies: the travel that
#: needs no further distance query (larger: fewer queries, each asking more bodies and points)
GAP_CAP = 0.05
#: states of a segment below which the outer bounds are not asked (one Bullet query costs about as much)
SURE_FREE_MIN = 2
#: states not known free the outer bounds meet before they stop a segment's first batch; each next batch
#: meets ``AHEAD_GROWTH`` times more. A walk stops at its first contact, usually one of the first such states
#: (a path checked into a collision): the states past it are never tested
AHEAD_FIRST = 2
AHEAD_GROWTH = 4
#: halvings of a parameter interval that place a curve's checked state (its travel known to ~1e-15 of it)
BISECTIONS = 50


def path_clearance(robot: BoundRobot, checker: CollisionChecker, start: FloatArray, guard: Guard,
                   *ends: FloatArray) -> float:
    """The clearance a path from ``start`` (through or to ``ends``) keeps: the guard's, or contact only
    when one of those states is closer. Both ends count alike, so a path and its reverse keep the same
    clearance (a path keeping the guard's clearance could not end at a state closer than it). The states
    the outer bounds find that far from everything (``CollisionChecker.sure_free``) are not asked of Bullet;
    a clearance above `TOUCH` returned thus says ``start`` is free of contact."""
    states = (start, *ends)
    known = np.zeros(len(states), dtype=bool)
    if checker.sure_free is not None and len(states) >= SURE_FREE_MIN:
        known = checker.sure_free(np.stack(states), guard.clearance, 0)[0]
    if known.all():
        return guard.clearance
    saved = robot.q.copy()
    try:
        for q, free in zip(states, known, strict=True):
            if not free:
                robot.apply(q)
                if not checker.is_free(guard.clearance):
                    return TOUCH
        return guard.clearance
    finally:
        robot.apply(saved)


def first_contact(robot: BoundRobot, checker: CollisionChecker, q0: FloatArray, q1: FloatArray,
                  guard: Guard, clearance: float) -> tuple[float, FloatArray] | None:
    """The first state between ``q0`` (excluded) and ``q1`` (included) closer than ``clearance`` to
    anything, as (fraction of the segment, state), or None (``first_contact_along`` of the segment)."""
    hit = first_contact_along(robot, checker, np.stack([q0, q1]), guard, clearance)
    return None if hit is None else (hit[1], hit[2])


def first_contact_along(robot: BoundRobot, checker: CollisionChecker, points: FloatArray, guard: Guard,
                        clearance: float) -> tuple[int, float, FloatArray] | None:
    """The first state along the polyline ``points`` (the first point excluded) closer than ``clearance``
    to anything, as (segment index, fraction of that segment, state), or None. Leaves the robot at the
    last state checked.

    Every segment is subdivided so that no point of the robot travels more than the guard's sweep between
    checked states. Every state is checked for self-contact. The distance to other bodies (which stand
    still during a check) is measured up to ``GAP_CAP`` beyond the clearance and then not again while the
    robot's travel since that measurement (the sweep bound, summed over the segments) keeps within the
    measured gap minus the clearance: no point can have come closer than the clearance meanwhile
    (conservative advancement). States the outer bounds find farther than the clearance from every other
    body and free of self-contact (``CollisionChecker.sure_free``) are not asked of Bullet at all. The
    verdict and the first contact are the same as measuring at every state; far from obstacles most
    queries are saved. A checkpoint (`world_thread.checkpoint`) before each segment and before each state
    asked of Bullet may let other robots move: the distance is then measured, and the states ahead
    classified, again. Between checkpoints nothing else moves, so the states found free stay free."""
    slack = -1.0  # travel left before the other bodies must be measured again
    applied = False  # whether the robot stands at the last state checked
    for j in range(len(points) - 1):
        q0, q1 = points[j], points[j + 1]
        n = substeps(q0, q1, guard.reach, guard.max_sweep)
        step = float(np.sum(np.abs(q1 - q0) * guard.reach)) / n
        states = q0 + (q1 - q0) * (np.arange(1, n + 1) / n)[:, None]
        if checkpoint():
            slack = -1.0
        ahead = Ahead(checker, states, clearance)
        done = 0  # states of the segment passed
        while True:
            k = ahead.unsure(done)  # the next state to ask Bullet; those before are free
            applied = applied and k == done
            slack -= step * (k - done)
            done = k
            if k == n:
                break
            if checkpoint():  # other bodies may have moved meanwhile: measure them again
                slack = -1.0
                ahead.forget(k)
                if ahead.unsure(k) != k:
                    continue
            q = states[k]
            slack -= step
            done = k + 1
            robot.apply(q)
            applied = True
            apart = clearance > TOUCH and slack >= 0.0
            if not apart and clearance > TOUCH:
                gap = checker.gap(clearance + GAP_CAP)
                if gap <= clearance:
                    return j, done / n, q
                apart, slack = True, gap - clearance
            if not checker.is_free(clearance, others_apart=apart):
                return j, done / n, q
    if not applied:
        robot.apply(points[-1])
    return None


class Ahead:
    """The states of a segment ahead of a walk, tested by the outer bounds (``CollisionChecker.sure_free``)
    in batches from the walk's position, each stopping once it met ``budget`` states not known free
    (``AHEAD_FIRST``, growing by ``AHEAD_GROWTH``): the states past the walk's first contact are mostly
    never tested."""

    def __init__(self, checker: CollisionChecker, states: FloatArray, clearance: float) -> None:
        self.checker, self.states, self.clearance = checker, states, clearance
        self.free = np.zeros(len(states), dtype=bool)
        self.known = 0  # the states before it are tested
        self.budget = AHEAD_FIRST
        self.asks = checker.sure_free is not None and len(states) >= SURE_FREE_MIN

    def unsure(self, k: int) -> int:
        """The first state from ``k`` on not known free (``len(states)``: none)."""
        n = len(self.states)
        while True:
            if k < self.known:
                left = np.flatnonzero(~self.free[k:self.known])
                if len(left):
                    return k + int(left[0])
                k = self.known
            if k >= n or not self.asks:
                return min(k, n)
            assert self.checker.sure_free is not None
            free, tested = self.checker.sure_free(self.states[k:], self.clearance, self.budget)
            self.free[k:k + tested] = free[:tested]
            self.known = k + tested
            self.budget *= AHEAD_GROWTH

    def forget(self, k: int) -> None:
        """The states from ``k`` on to be tested again (other bodies may have moved)."""
        self.known = min(self.known, k)
        self.budget = AHEAD_FIRST


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


def curve_checkpoints(curve: Curve, reach: FloatArray, spacing: float) -> FloatArray:
    """Path parameters along ``curve`` (from 0 to 1) between which no point of the robot travels more than
    ``spacing`` (m) along the curve: the travel between two parameters is bounded by sum_j reach_j x the
    variation of joint j, which between two of ``Curve.monotone_params`` (each joint moving one way) is
    exactly sum_j reach_j |dq_j|; within one of those intervals the parameter reaching a travel is found
    by bisection. How many there are depends on how far the robot travels, not on how slowly."""
    grid = curve.monotone_params()
    q = curve.states(grid)
    travel = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(q, axis=0)) @ reach)])
    n = max(1, math.ceil(travel[-1] / (spacing * (1.0 - 1e-6))))
    levels = travel[-1] * np.arange(1, n) / n
    cell = np.clip(np.searchsorted(travel, levels, side="right") - 1, 0, len(grid) - 2)
    lo, hi = grid[cell].copy(), grid[cell + 1].copy()
    base, need = q[cell], levels - travel[cell]
    for _ in range(BISECTIONS):  # the travel from the cell's start grows with the parameter
        mid = 0.5 * (lo + hi)
        short = np.abs(curve.states(mid) - base) @ reach < need
        lo, hi = np.where(short, mid, lo), np.where(short, hi, mid)
    return np.concatenate([[0.0], lo, [1.0]])


def _curve_contact(robot: BoundRobot, checker: CollisionChecker, curve: Curve, guard: Guard,
                   clearance: float) -> tuple[float, FloatArray] | None:
    """The first contact along ``curve`` (its first state excluded) as (fractional step index, state).

    Its states lie on the spline. When no two consecutive states are farther apart than the clearance
    (half the guard's sweep; ``Curve.row_travel_bound``), the states at ``curve_checkpoints`` spaced by the
    sweep are checked: a point of the move between two consecutive states either lies between the same
    two checked states (its travels to both, summed, are at most the travel along the curve between them:
    the sweep), or that move passes a checked state (then it is within the move's own travel, at most
    the clearance, of it); within the clearance of a checked state either way, so it cannot touch
    (``sweep.py``). Otherwise (a fast curve: its states are few) the states themselves are checked, as a
    polyline."""
    if curve.row_travel_bound(guard.reach) <= guard.clearance:
        params = curve_checkpoints(curve, guard.reach, guard.max_sweep)
        points = curve.states(params)
        points[0], points[-1] = curve.first, curve.last
        hit = first_contact_along(robot, checker, points, guard, clearance)
        if hit is None:
            return None
        j, frac, q = hit
        return curve.index_of(float(params[j] + frac * (params[j + 1] - params[j]))), q
    rows = curve.at(np.arange(curve.steps + 1, dtype=np.int64))
    corners = _vertices(rows)
    hit = first_contact_along(robot, checker, rows[corners], guard, clearance)
    if hit is None:
        return None
    j, frac, q = hit
    a, b = corners[j], corners[j + 1]
    # the rows between two vertices lie on the segment in order: the time is where the hit's distance
    # along it falls among theirs
    along = np.linalg.norm(rows[a:b + 1] - rows[a], axis=1)
    return a + float(np.interp(frac * along[-1], along, np.arange(b - a + 1))), q


def check_joint_path(robot: BoundRobot, checker: CollisionChecker, path: TimedPath,
                     guard: Guard) -> PathReport:
    """Check ``path`` (its states and the moves between them) and report the first contact. A straight
    piece is checked as one segment, however it accelerates along it; a curve at points spaced by travel
    (``_curve_contact``). The cost depends on how far the robot travels, not on how slowly (the number
    of states)."""
    saved = robot.q.copy()
    try:
        first = path.first
        clearance = path_clearance(robot, checker, first, guard, path.last)
        resume = 0.0
        start: tuple[Contact, ...] = ()
        # above TOUCH the start was found that far from everything: free of contact
        if clearance <= TOUCH and not _free_at(robot, checker, first):
            # a start in contact: the path may leave it while the contact recedes (``exit_contact.py``)
            left = leave_contact(robot, checker, path, guard)
            start = left.start
            if left.free_at is None:
                report = FirstCollision(left.at * path.dt, left.positions, left.contacts)
                return PathReport(False, path.duration, len(path), report, start)
            resume = left.free_at
        for offset, piece in path.offsets():
            if piece.steps == 0 or offset + piece.steps <= resume:
                continue
            found = _piece_contact(robot, checker, piece, guard, clearance, max(0.0, resume - offset))
            if found is not None:
                at, q = found
                report = FirstCollision((offset + at) * path.dt, tuple(float(x) for x in np.asarray(q)),
                                        tuple(checker.contacts(clearance)))
                return PathReport(False, path.duration, len(path), report, start)
    finally:
        robot.apply(saved)
    return PathReport(True, path.duration, len(path), None, start)


def _free_at(robot: BoundRobot, checker: CollisionChecker, q: FloatArray) -> bool:
    """Whether state ``q`` is free of contact (Bullet's check; the robot left there)."""
    robot.apply(q)
    return checker.is_free()


def _piece_contact(robot: BoundRobot, checker: CollisionChecker, piece: Piece, guard: Guard,
                   clearance: float, after: float) -> tuple[float, FloatArray] | None:
    """The first contact along ``piece`` after its fractional state index ``after`` (0: its first state,
    excluded), as (fractional state index, state). Only a path leaving a contact starts past 0: a straight
    piece from the state there to its end (the state lies on the segment), a curve along its states
    from there as a polyline."""
    if isinstance(piece, Straight):
        if after <= 0.0:
            hit = first_contact(robot, checker, piece.start, piece.target, guard, clearance)
            return None if hit is None else (piece.index_of(hit[0]), hit[1])
        k = int(after)
        q = piece.at(np.array([k, min(k + 1, piece.steps)], dtype=np.int64))
        q_from = q[0] + (q[1] - q[0]) * (after - k)
        span = piece.target - piece.start
        done = float(np.dot(q_from - piece.start, span) / max(float(np.dot(span, span)), 1e-300))
        hit = first_contact(robot, checker, q_from, piece.target, guard, clearance)
        return None if hit is None else (piece.index_of(done + hit[0] * (1.0 - done)), hit[1])
    assert isinstance(piece, Curve)
    if after <= 0.0:
        return _curve_contact(robot, checker, piece, guard, clearance)
    k = int(after)
    rows = piece.at(np.arange(k, piece.steps + 1, dtype=np.int64))
    rows[0] = rows[0] + (rows[min(1, len(rows) - 1)] - rows[0]) * (after - k)
    corners = _vertices(rows)
    along = first_contact_along(robot, checker, rows[corners], guard, clearance)
    if along is None:
        return None
    j, frac, q = along
    return k + corners[j] + frac * (corners[j + 1] - corners[j]), q


def check_states(scene: Scene, robot_id: str, path: TimedPath) -> PathReport:
    """``check_joint_path`` of a robot of ``scene`` (its state unchanged)."""
    e = scene.entry(robot_id)
    with scene.holding(robot_id):
        return check_joint_path(e.bound, e.checker, path, e.guard)


def check_path(scene: Scene, robot_id: str, target: JointVector, start: JointVector | None = None,
               speed: float = DEFAULT_SPEED, dt: float = DEFAULT_DT,
               via: Sequence[JointVector] = ()) -> PathReport:
    """The path a move from ``start`` (default: the current state) through ``via`` to ``target`` runs
    (``trajectory.plan_motion``), checked (``check_states``)."""
    return check_states(scene, robot_id, plan_motion(scene, robot_id, target, start, speed, dt, via))


def motion_clearance(scene: Scene, robot_id: str, *through: JointVector) -> float:
    """The clearance (m) a motion of a robot of ``scene`` from its current state through (or to) the
    states ``through`` keeps (``path_clearance``)."""
    e = scene.entry(robot_id)
    return path_clearance(e.bound, e.checker, e.bound.q.copy(), e.guard,
                          *(e.bound.validate(q, "through") for q in through))


def check_step(scene: Scene, robot_id: str, q_from: JointVector, q_to: JointVector,
               clearance: float) -> CollisionReport:
    """Contacts on the way from ``q_from`` to ``q_to`` (``first_contact``: other bodies closer than
    ``clearance`` count). The robot's state unchanged."""
    e = scene.entry(robot_id)
    saved = e.bound.q.copy()
    try:
        hit = first_contact(e.bound, e.checker, np.asarray(q_from, dtype=np.float64),
                            np.asarray(q_to, dtype=np.float64), e.guard, clearance)
        contacts = e.checker.contacts(clearance) if hit is not None else []
    finally:
        e.bound.apply(saved)
    return CollisionReport(hit is None, tuple(contacts))
