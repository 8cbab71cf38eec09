"""The robots' own points in a scan: every collision shape of every robot of the world, as Bullet holds it
at the robots' current joints (an object a gripper holds is a link of its robot, so it goes with it).

A point is the robots' when it lies within ``padding`` of one of those shapes' convex hulls (each hull's
facet planes moved out by ``padding``: near an edge that reaches a little farther than ``padding``). The
snapshot is taken on the world's thread (``snapshot``); the points are tested anywhere (``robot_mask``).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pybullet as pb
from scipy.spatial import ConvexHull, QhullError

from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.robot_shapes import link_parts

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

#: points tested against one hull at a time (bounds the temporary [points, facets] array)
CHUNK = 65_536


class Hull(NamedTuple):
    """One collision shape in the world: its facet planes (``normal . x + offset <= 0`` inside) and the
    box around it."""

    equations: FloatArray  # [f, 4]
    lo: FloatArray  # [3]
    hi: FloatArray  # [3]


class RobotSnapshot(NamedTuple):
    """The world's robots as a scan sees them: every collision shape's hull, and per robot the lowest
    point of its links that never move (what it stands on) and the box around them."""

    hulls: list[Hull]
    stands: list[tuple[FloatArray, FloatArray]]  # per robot: (lo, hi) of its fixed links' shapes


def _world_points(cid: int, body: int, link: int) -> list[FloatArray]:
    """A link's collision shapes as points whose hulls hold them, in the world frame."""
    parts = link_parts(cid, body, link) or []
    if link < 0:  # the base's parts come in the world frame
        return parts
    state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=cid)
    position, rotation = np.asarray(state[4], dtype=np.float64), quat_matrix(state[5])
    return [position + p @ rotation.T for p in parts]


def _hull(points: FloatArray) -> Hull | None:
    """The hull of a shape's points (None for a degenerate shape: it holds no volume to be inside)."""
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return None
    return Hull(np.asarray(hull.equations, dtype=np.float64), points.min(axis=0), points.max(axis=0))


def snapshot(scene: Any) -> RobotSnapshot:
    """Every robot of ``scene`` (a ``planning_scene.Scene``) at its current joints: call on the world's
    thread."""
    hulls: list[Hull] = []
    stands: list[tuple[FloatArray, FloatArray]] = []
    for entry in scene.entries().values():
        bound = entry.bound
        cid, body = bound.bullet.cid, bound.body
        fixed = set(entry.checker.static_links)
        low: list[FloatArray] = []
        for link in bound.link_index.values():
            for points in _world_points(cid, body, link):
                hull = _hull(points)
                if hull is not None:
                    hulls.append(hull)
                if link in fixed:
                    low.append(points)
        if low:
            every = np.concatenate(low)
            stands.append((every.min(axis=0), every.max(axis=0)))
    return RobotSnapshot(hulls, stands)


def robot_mask(points: FloatArray, robots: RobotSnapshot, padding: float) -> BoolArray:
    """True for each of ``points`` [n, 3] within ``padding`` (m) of a robot's collision shape."""
    out = np.zeros(len(points), dtype=bool)
    if not robots.hulls or not len(points):
        return out
    lo = np.min([h.lo for h in robots.hulls], axis=0) - padding
    hi = np.max([h.hi for h in robots.hulls], axis=0) + padding
    near = np.flatnonzero(((points >= lo) & (points <= hi)).all(axis=1))
    for hull in robots.hulls:
        inside_box = ((points[near] >= hull.lo - padding) & (points[near] <= hull.hi + padding)).all(axis=1)
        candidates = near[inside_box]
        for start in range(0, len(candidates), CHUNK):
            idx = candidates[start:start + CHUNK]
            signed = points[idx] @ hull.equations[:, :3].T + hull.equations[:, 3]
            out[idx[signed.max(axis=1) <= padding]] = True
        near = near[~out[near]]
    return out
