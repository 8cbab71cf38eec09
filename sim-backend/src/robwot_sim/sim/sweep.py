"""How far any point of a robot can move for a joint step: what makes a discrete path check sound.

A path is checked at states; between two checked states every point of the robot travels at most
``sweep(q0, q1) = sum_k |q1_k - q0_k| * reach_k``. If every checked state keeps a clearance ``c`` to other
bodies and the sweep between neighbours is at most ``2 c``, no point can have touched anything in
between (a point that moved at most ``2 c`` stays within ``c`` of one of the two states, where it was
farther than ``c`` from every obstacle). ``reach_k`` bounds the distance of any collision point of the
links joint k moves from its axis, from the rigid chain: the distances between consecutive link frames
plus the radius of each link's collision shape about its frame (from its bounding box, so never less).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robwot_sim.limits import DEFAULT_CLEARANCE
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import FloatArray

#: largest travel of any robot point between two checked states (m): twice the default clearance
MAX_SWEEP = 2 * DEFAULT_CLEARANCE


@dataclass(frozen=True)
class Guard:
    """What a path check of one robot keeps: ``clearance`` (m) to other bodies, no point travelling more
    than twice that between checked states (``reach``: per joint, how far the farthest collision point
    travels per unit of motion, from ``joint_reach``)."""

    reach: FloatArray
    clearance: float = DEFAULT_CLEARANCE

    @property
    def max_sweep(self) -> float:
        return 2.0 * self.clearance


def joint_reach(robot: BoundRobot) -> FloatArray:
    """Per controllable joint: metres travelled by the farthest collision point per radian (revolute) or
    per metre (prismatic: 1) of joint motion, mimic followers included."""
    b, body = robot.bullet, robot.body
    infos = b.joints(body)
    children: dict[int, list[int]] = {-1: []}
    for ji in infos:
        children.setdefault(ji.parent_index, []).append(ji.idx)
        children.setdefault(ji.idx, [])
    origin = {ln: np.array(b.link_frame(body, ln)[0]) for ln in children}
    radius = {ln: b.link_radius(body, ln) for ln in children}

    def farthest(ln: int) -> float:
        """Largest distance from ``ln``'s frame origin to any collision point of ``ln`` or below it."""
        best = radius[ln]
        for child in children[ln]:
            best = max(best, float(np.linalg.norm(origin[child] - origin[ln])) + farthest(child))
        return best

    prismatic = {ji.idx for ji in infos if ji.type == pb.JOINT_PRISMATIC}
    per_link = {ln: (1.0 if ln in prismatic else farthest(ln)) for ln in children if ln >= 0}
    reach = np.array([per_link[i] for i in robot.ctrl_idx], dtype=np.float64)
    follow = robot.followers
    if len(follow):
        # a follower turns by sum(|factor| * leader's turn): its links' travel is owed to its leaders
        reach += np.abs(follow.matrix).T @ np.array([per_link[i] for i in robot.set_idx[robot.dof:]])
    return reach


def substeps(q0: FloatArray, q1: FloatArray, reach: FloatArray, max_sweep: float = MAX_SWEEP) -> int:
    """How many equal steps from ``q0`` to ``q1`` keep every point's travel per step <= ``max_sweep``."""
    travel = float(np.sum(np.abs(q1 - q0) * reach))
    return max(1, math.ceil(travel / max_sweep))
