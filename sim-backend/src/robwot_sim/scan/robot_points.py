"""The robots' own points in a scan: every collision shape of every robot of the world, as Bullet holds it
at the robots' current joints (an object a gripper holds is a link of its robot, so it goes with it).

A point is the robots' when it lies within ``padding`` of one of those shapes' convex hulls (each hull
slimmed outward to few facets, by at most ``robot_shapes.SLIM``; its facet planes moved out by
``padding``: near an edge that reaches a little farther). The
snapshot is taken on the world's thread (``snapshot``); the points are tested anywhere (``robot_mask``).
"""

from __future__ import annotations

from collections import OrderedDict
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pybullet as pb
from scipy.spatial import ConvexHull, QhullError

from robwot_sim.model.rotations import quat_matrix
from robwot_sim.scan.segment import within
from robwot_sim.sim.robot_shapes import hull_vertices, link_parts

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


#: per robot body as loaded (client, body, its URDF, its base pose): each collision shape's slimmed hull in
#: its link's frame (the base's: the world's), as vertices and facet planes; the robots' shapes never
#: change while the body stands, so a scan pays for them once
_LOCAL: OrderedDict[tuple[Any, ...], list[tuple[int, FloatArray, FloatArray]]] = OrderedDict()
_KEPT = 16


LocalHull = tuple[int, FloatArray, FloatArray]


def _local_hulls(cid: int, body: int, links: list[int], urdf: str) -> list[LocalHull]:
    """Every collision shape of a body's ``links`` as (link, hull vertices, facet planes) in its link's
    frame, slimmed outward by at most ``robot_shapes.SLIM`` to few facets; degenerate shapes left out."""
    base = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
    key = (cid, body, hash(urdf), tuple(base[0]), tuple(base[1]))
    if key in _LOCAL:
        _LOCAL.move_to_end(key)
        return _LOCAL[key]
    out = []
    for link in links:
        for points in link_parts(cid, body, link) or []:
            try:
                vertices = hull_vertices(points)
                out.append((link, vertices, np.asarray(ConvexHull(vertices).equations, dtype=np.float64)))
            except (QhullError, ValueError):  # a flat or degenerate shape has no inside
                continue
    _LOCAL[key] = out
    while len(_LOCAL) > _KEPT:
        _LOCAL.popitem(last=False)
    return out


def _placed(cid: int, body: int, link: int, vertices: FloatArray,
            planes: FloatArray) -> tuple[FloatArray, Hull]:
    """A link-frame hull placed where its link is now: its vertices and its ``Hull``."""
    if link < 0:  # the base's shapes are kept in the world frame
        return vertices, Hull(planes, vertices.min(axis=0), vertices.max(axis=0))
    state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=cid)
    position, rotation = np.asarray(state[4], dtype=np.float64), quat_matrix(state[5])
    world = position + vertices @ rotation.T
    normals = planes[:, :3] @ rotation.T
    offsets = planes[:, 3] - normals @ position
    return world, Hull(np.column_stack([normals, offsets]), world.min(axis=0), world.max(axis=0))


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
        links = list(bound.link_index.values())
        for link, vertices, planes in _local_hulls(cid, body, links, entry.loaded_urdf):
            world, hull = _placed(cid, body, link, vertices, planes)
            hulls.append(hull)
            if link in fixed:
                low.append(world)
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
    near = np.flatnonzero(within(points, lo, hi))
    for hull in robots.hulls:
        candidates = near[within(points[near], hull.lo - padding, hull.hi + padding)]
        for start in range(0, len(candidates), CHUNK):
            idx = candidates[start:start + CHUNK]
            signed = points[idx] @ hull.equations[:, :3].T + hull.equations[:, 3]
            out[idx[signed.max(axis=1) <= padding]] = True
        near = near[~out[near]]
    return out
