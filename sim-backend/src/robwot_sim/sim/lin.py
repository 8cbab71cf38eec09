"""LIN: the end effector (the TCP with a tool) on the straight line from its current pose to a target pose,
its orientation turned by slerp on the way.

The line is followed by IK samples, each seeded with the previous one, so the configuration stays on one
branch: a joint that would jump more than ``MAX_JOINT_STEP`` between neighbouring samples (a
configuration flip, or a singularity where the joints race) is refused, naming the joint and where on the
line. Samples are ``LIN_STEP`` / ``LIN_ANGLE_STEP`` apart and split further where the end effector, moved
straight in joint space between two samples, would leave the line by more than ``MAX_DEVIATION``. Every
segment between samples is then checked for contacts as any path is (clearance kept). The result is the
joint waypoints from the current state to the target.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
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
#: times a segment may be halved to keep the deviation or the joint step
MAX_SPLITS = 5


@dataclass
class LinPath:
    """Joint waypoints along the line (the current state first), or why there are none."""

    waypoints: list[FloatArray] = field(default_factory=list)
    reason: str | None = None
    contacts: list[Contact] = field(default_factory=list)
    #: the largest deviation from the line (m) at the midpoints between samples
    deviation: float = 0.0


def lin_path(world: World, robot: str, position: Sequence[float],
             orientation: Sequence[float] | None) -> LinPath:
    """The LIN from the robot's current state to ``position`` (+ ``orientation``; default: the current
    orientation kept). Read-only: the world is unchanged."""
    q0 = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
    start = world.fk(robot, q0)
    p0, p1 = np.asarray(start.position), np.asarray(position, dtype=np.float64)
    r0 = tuple(start.quat_xyzw)
    r1 = tuple(orientation) if orientation is not None else r0
    length = float(np.linalg.norm(p1 - p0))
    turn = quat_angle(r0, r1)
    steps = max(1, math.ceil(length / LIN_STEP), math.ceil(turn / LIN_ANGLE_STEP))
    names = world.robot_model(robot).controllable
    out = LinPath(waypoints=[q0])

    def where(s: float) -> str:
        if length > 0:
            return f"{1000 * s * length:.0f} mm along the line"
        return f"{math.degrees(s * turn):.1f} deg into the turn"

    def solve(s: float, seed: FloatArray) -> FloatArray | None:
        checkpoint()
        target = p0 + s * (p1 - p0)
        try:
            ik = world.ik(robot, tuple(target), quat_slerp(r0, r1, s), seed=list(seed), collision_free=False)
        except Unreachable:
            ik = None
        if (ik is None or ik.position_error > IK_POSITION_TOLERANCE
                or ik.orientation_error > IK_ORIENTATION_TOLERANCE):
            out.reason = f"the line leaves the robot's reach {where(s)}: no IK solution keeps the pose there"
            return None
        return np.asarray(ik.positions, dtype=np.float64)

    def segment(sa: float, qa: FloatArray, sb: float, qb: FloatArray, splits: int) -> bool:
        """Appends the waypoints after ``qa`` up to ``qb``, splitting where needed."""
        jump = np.abs(qb - qa)
        mid_q = (qa + qb) / 2
        mid_line = p0 + (sa + sb) / 2 * (p1 - p0)
        deviation = float(np.linalg.norm(np.asarray(world.fk(robot, mid_q).position) - mid_line))
        if jump.max() <= MAX_JOINT_STEP and deviation <= MAX_DEVIATION:
            out.deviation = max(out.deviation, deviation)
            out.waypoints.append(qb)
            return True
        if splits >= MAX_SPLITS:
            if jump.max() > MAX_JOINT_STEP:
                j = int(np.argmax(jump))
                out.reason = (f"joint {names[j]} would turn {jump[j]:.2f} rad within "
                              f"{1000 * (sb - sa) * length:.2f} mm {where(sa)}: a configuration flip or a "
                              "singularity on the line")
            else:
                out.reason = f"the end effector leaves the line by {1000 * deviation:.2f} mm {where(sa)}"
            return False
        sm = (sa + sb) / 2
        qm = solve(sm, qa)
        return qm is not None and segment(sa, qa, sm, qm, splits + 1) and segment(sm, qm, sb, qb, splits + 1)

    q_prev = q0
    for i in range(1, steps + 1):
        s = i / steps
        q = solve(s, q_prev)
        if q is None or not segment((i - 1) / steps, q_prev, s, q, 0):
            out.waypoints = []
            return out
        q_prev = q
    clearance = world.motion_clearance(robot)
    for qa, qb in itertools.pairwise(out.waypoints):
        checkpoint()
        report = world.check_step(robot, qa, qb, clearance)
        if not report.collision_free:
            out.contacts = list(report.contacts)
            out.reason = "the line collides"
            out.waypoints = []
            return out
    return out
