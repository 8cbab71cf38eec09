"""LIN and CIRC: the end effector (the TCP with a tool) on the straight line, or on the circular arc through
a via point, from its current pose to a target pose, its orientation turned by slerp on the way.

The curve is followed by differential IK (``ik.Tracker``): each sample solved from the joints of the
previous one only (damped least squares kept near them, never a random restart), in smaller steps where
one does not converge, so the configuration stays on the branch it starts on. Where that branch ends the
curve is refused saying why: a joint at its limit, a singularity (the Jacobian's smallest singular value),
the robot's reach, or that only another configuration reaches it (a flip); joints that still race between
neighbouring samples (more than ``MAX_JOINT_STEP``) are refused naming the joint. Samples are
``LIN_STEP`` / ``LIN_ANGLE_STEP`` apart and split further where the end effector, moved straight in joint
space between two samples, would leave the curve by more than ``MAX_DEVIATION``. Every segment between
samples is then checked for contacts as any path is (clearance kept), the part followed also when the
curve ends further on: the refusal names the first cause along it. The result is the joint waypoints from
the current state to the target.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import Unreachable
from robwot_sim.model.rotations import quat_angle, quat_slerp
from robwot_sim.sim.types import Contact
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import checkpoint

FloatArray = npt.NDArray[np.float64]

#: metres of line, and radians of turn, between IK samples before any split
LIN_STEP = 0.005
LIN_ANGLE_STEP = math.radians(2.0)
#: metres the end effector may leave the line between two samples (moved straight in joint space)
MAX_DEVIATION = 0.0005
#: radians a joint may turn between neighbouring samples; more is a flip or a singularity
MAX_JOINT_STEP = 0.35
#: IK residuals a sample must meet (m, rad)
IK_POSITION_TOLERANCE = 1e-4
IK_ORIENTATION_TOLERANCE = math.radians(0.5)
#: the sine of the angle at the via point below which start, via and target count as on one line
ONE_LINE = 1e-6
#: times a segment may be halved to keep the deviation or the joint step
MAX_SPLITS = 5
#: sub-steps tried, one count after the other, where tracking a sample from the previous one in one step
#: does not converge (the linearisation is poor near a singularity)
TRACK_PARTS = (1, 4, 16)


@dataclass
class LinPath:
    """Joint waypoints along the line (the current state first), or why there are none."""

    waypoints: list[FloatArray] = field(default_factory=list)
    reason: str | None = None
    contacts: list[Contact] = field(default_factory=list)
    #: the largest deviation from the line (m) at the midpoints between samples
    deviation: float = 0.0
    #: the end effector's distance along the curve (m) at each waypoint
    arc: list[float] = field(default_factory=list)


def lin_path(world: World, robot: str, position: Sequence[float],
             orientation: Sequence[float] | None) -> LinPath:
    """The LIN from the robot's current state to ``position`` (+ ``orientation``; default: the current
    orientation kept). Read-only: the world is unchanged."""
    q0 = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
    start = world.fk(robot, q0)
    p0, p1 = np.asarray(start.position), np.asarray(position, dtype=np.float64)
    length = float(np.linalg.norm(p1 - p0))
    return _follow(world, robot, q0, start.quat_xyzw, orientation, lambda s: p0 + s * (p1 - p0), length,
                   "the line")


def circ_path(world: World, robot: str, via: Sequence[float], position: Sequence[float],
              orientation: Sequence[float] | None) -> LinPath:
    """The CIRC from the robot's current state through ``via`` to ``position`` (+ ``orientation``): the
    arc of the circle through the three points that passes ``via``. Three points on one line (or two of
    them the same) make no circle: refused. Read-only."""
    q0 = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
    start = world.fk(robot, q0)
    a, b, c = (np.asarray(x, dtype=np.float64) for x in (start.position, via, position))
    normal = np.cross(b - a, c - b)
    if np.linalg.norm(normal) < ONE_LINE * max(1e-9, float(np.linalg.norm(c - a)) ** 2) or min(
            np.linalg.norm(b - a), np.linalg.norm(c - b)) < 1e-4:
        return LinPath(reason="the start, via point and target lie on one line (or two of them coincide): "
                              "they define no arc")
    n = normal / np.linalg.norm(normal)
    # the centre: the point of the plane equidistant from the three (intersection of the bisectors)
    u_ac, u_bc = a - c, b - c
    cross = np.cross(u_ac, u_bc)
    centre = c + np.cross(u_ac @ u_ac * u_bc - u_bc @ u_bc * u_ac, cross) / (2 * cross @ cross)
    radius = float(np.linalg.norm(a - centre))
    e1 = (a - centre) / radius
    e2 = np.cross(n, e1)

    def angle(x: FloatArray) -> float:
        d = x - centre
        return float(np.arctan2(d @ e2, d @ e1)) % (2 * math.pi)

    sweep = angle(c)  # a -> via -> c turns positively about n, so the arc's sweep is c's angle

    def point(s: float) -> FloatArray:
        t = s * sweep
        return centre + radius * (math.cos(t) * e1 + math.sin(t) * e2)

    return _follow(world, robot, q0, start.quat_xyzw, orientation, point, radius * sweep, "the arc")


def _follow(world: World, robot: str, q0: FloatArray, r0_: Sequence[float],
            orientation: Sequence[float] | None, point: Callable[[float], FloatArray], length: float,
            curve: str) -> LinPath:
    """Joint waypoints keeping the end effector on ``point(s)``, s in [0, 1] (``length`` metres long),
    its orientation from ``r0_`` to ``orientation`` by slerp."""
    r0 = tuple(r0_)
    r1 = tuple(orientation) if orientation is not None else r0
    turn = quat_angle(r0, r1)
    steps = max(1, math.ceil(length / LIN_STEP), math.ceil(turn / LIN_ANGLE_STEP))
    names = world.robot_model(robot).controllable
    out = LinPath(waypoints=[q0], arc=[0.0])

    def where(s: float) -> str:
        if length > 0:
            return f"{1000 * s * length:.0f} mm along {curve}"
        return f"{math.degrees(s * turn):.1f} deg into the turn"

    tracker = world.tracker(robot, IK_POSITION_TOLERANCE, IK_ORIENTATION_TOLERANCE)

    def solve(s: float, seed: FloatArray, s_seed: float) -> FloatArray | None:
        """The joints at ``s``, tracked from ``seed`` (the joints at ``s_seed``) on its branch, in smaller
        steps where one does not converge; None with the reason when the branch ends."""
        checkpoint()
        target, quat = point(s), quat_slerp(r0, r1, s)
        for parts in TRACK_PARTS:
            q: FloatArray | None = seed
            for k in range(1, parts + 1):
                ends = s_seed + (s - s_seed) * k / parts
                assert q is not None
                q, cause = tracker.step(q, tuple(point(ends)), quat_slerp(r0, r1, ends))
                if q is None:
                    break
            if q is not None:
                return q
        if cause is not None:
            out.reason = f"{curve} cannot be followed {where(ends)}: {cause}"
        else:  # neither a limit nor a singularity: beyond the reach, or only on another branch
            out.reason = _off_branch(world, robot, target, quat, seed, f"{curve} %s {where(s)}")
        return None

    def segment(sa: float, qa: FloatArray, sb: float, qb: FloatArray, splits: int) -> bool:
        """Appends the waypoints after ``qa`` up to ``qb``, splitting where needed."""
        jump = np.abs(qb - qa)
        mid_q = (qa + qb) / 2
        mid_line = point((sa + sb) / 2)
        deviation = float(np.linalg.norm(np.asarray(world.fk(robot, mid_q).position) - mid_line))
        if jump.max() <= MAX_JOINT_STEP and deviation <= MAX_DEVIATION:
            out.deviation = max(out.deviation, deviation)
            out.waypoints.append(qb)
            out.arc.append(sb * length)
            return True
        if splits >= MAX_SPLITS:
            if jump.max() > MAX_JOINT_STEP:
                j = int(np.argmax(jump))
                out.reason = (f"joint {names[j]} would turn {jump[j]:.2f} rad within "
                              f"{1000 * (sb - sa) * length:.2f} mm {where(sa)}: "
                              f"{tracker.singular_words(qa)} on {curve}")
            else:
                out.reason = f"the end effector leaves {curve} by {1000 * deviation:.2f} mm {where(sa)}"
            return False
        sm = (sa + sb) / 2
        qm = solve(sm, qa, sa)
        return qm is not None and segment(sa, qa, sm, qm, splits + 1) and segment(sm, qm, sb, qb, splits + 1)

    q_prev = q0
    followed = True
    for i in range(1, steps + 1):
        s = i / steps
        q = solve(s, q_prev, (i - 1) / steps)
        if q is None or not segment((i - 1) / steps, q_prev, s, q, 0):
            followed = False
            break
        q_prev = q
    # the part followed is checked for contacts even when the curve ends further on: a contact there is
    # the first cause along it
    if _touches(world, robot, out, curve) or not followed:
        out.waypoints, out.arc = [], []
    return out


def _off_branch(world: World, robot: str, target: FloatArray, quat: Sequence[float], seed: FloatArray,
                template: str) -> str:
    """Why a pose the tracked branch does not reach, with no limit or singularity to say it, cannot be
    followed: no IK solution at all (beyond the reach), or only one on another branch (a flip).
    ``template`` has ``%s`` where the verb goes."""
    try:
        ik = world.ik(robot, tuple(target), quat, seed=list(seed), collision_free=False)
    except Unreachable:
        ik = None
    if (ik is None or ik.position_error > IK_POSITION_TOLERANCE
            or ik.orientation_error > IK_ORIENTATION_TOLERANCE):
        return template % "leaves the robot's reach" + ": no IK solution keeps the pose there"
    names = world.robot_model(robot).controllable
    jump = np.abs(np.asarray(ik.positions) - seed)
    j = int(np.argmax(jump))
    return (template % "cannot be followed continuously" + f": only another configuration reaches it "
            f"(joint {names[j]} {jump[j]:.2f} rad away), a configuration flip")


def _touches(world: World, robot: str, out: LinPath, curve: str) -> bool:
    """Whether a segment between ``out``'s waypoints collides (clearance kept); its contacts and the
    reason then in ``out``."""
    clearance = world.motion_clearance(robot, out.waypoints[-1])
    for qa, qb in itertools.pairwise(out.waypoints):
        checkpoint()
        report = world.check_step(robot, qa, qb, clearance)
        if not report.collision_free:
            out.contacts = list(report.contacts)
            out.reason = f"{curve} collides"
            return True
    return False
