"""How far any point of a robot can move for a joint step: what makes a discrete path check sound.

A path is checked at states; between two checked states every point of the robot travels at most
``sweep(q0, q1) = sum_k |q1_k - q0_k| * reach_k``. If every checked state keeps a clearance ``c`` to other
bodies and the sweep between neighbours is at most ``2 c``, no point can have touched anything in
between (a point that moved at most ``2 c`` stays within ``c`` of one of the two states, where it was
farther than ``c`` from every obstacle). ``reach_k`` bounds the distance of any collision point of the
links joint k moves from its axis (a point at distance d from the axis travels d per radian), from the
rigid chain: for joint k's own link, the distance from the axis of its collision bounding box's corners;
below it, the distance from the axis of the next joint's origin (a constant of the link, as the axis is)
plus, from that origin on, the distances between consecutive link frames and each link's box's farthest
corner from its frame. A box holds its link's shapes, and the distance from a point or from a line is
convex, so no point of the shapes is farther than the box's farthest corner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet as pb

from robwot_sim.limits import DEFAULT_CLEARANCE
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.client import JointInfo
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
    per metre (prismatic: 1) of joint motion, mimic followers included (module docstring)."""
    b, body = robot.bullet, robot.body
    infos = b.joints(body)
    children: dict[int, list[int]] = {-1: []}
    for ji in infos:
        children.setdefault(ji.parent_index, []).append(ji.idx)
        children.setdefault(ji.idx, [])
    frame = {ln: b.link_frame(body, ln) for ln in children}
    origin = {ln: np.array(frame[ln][0]) for ln in children}
    corners = {ln: b.link_box_corners(body, ln) - origin[ln] for ln in children}  # (0, 3): no shape
    radius = {ln: float(np.linalg.norm(c, axis=1).max(initial=0.0)) for ln, c in corners.items()}

    def farthest(ln: int) -> float:
        """Largest distance from ``ln``'s frame origin to any collision point of ``ln`` or below it."""
        best = radius[ln]
        for child in children[ln]:
            best = max(best, float(np.linalg.norm(origin[child] - origin[ln])) + farthest(child))
        return best

    def about_axis(ji: JointInfo) -> float:
        """Largest distance from joint ``ji``'s axis to any collision point of its link or below it."""
        axis = quat_matrix(frame[ji.idx][1]) @ np.asarray(ji.axis, dtype=np.float64)
        axis /= np.linalg.norm(axis)
        c = corners[ji.idx]
        best = float(np.linalg.norm(c - np.outer(c @ axis, axis), axis=1).max(initial=0.0))
        for child in children[ji.idx]:
            d = origin[child] - origin[ji.idx]
            best = max(best, float(np.linalg.norm(d - (d @ axis) * axis)) + farthest(child))
        return best

    per_link = {ji.idx: 1.0 if ji.type == pb.JOINT_PRISMATIC else
                about_axis(ji) if ji.type == pb.JOINT_REVOLUTE else farthest(ji.idx) for ji in infos}
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
