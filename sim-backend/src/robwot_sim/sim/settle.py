"""Objects at rest: where an added or moved object comes to rest under gravity, and whether it may be put
there.

An object settles in a PyBullet client of its own, built for that one settling: the floor plane z = 0, the
obstacles and other objects in the objects' column (their bounding boxes under or beside them) static, the
settling objects with their masses. Robots are not in it: they hold nothing up (an object dropped above an
arm falls through it) and are checked against the pose it comes to rest at instead. The same bodies in the
same order give the same steps, so the same input gives the same pose. The planning scene
(``planning_scene.Scene``) keeps every object as a static body at that pose, as its obstacles.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from robwot_sim.errors import Overlap
from robwot_sim.limits import OVERLAP_TOLERANCE, SETTLE_STEPS
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.client import HULL, Bullet, Quat, Vec3
from robwot_sim.sim.collision import BodyTable

#: physics steps between two checks of whether the settling objects are at rest (0.1 s at 1/240 s a step)
CHECK_EVERY = 24
#: at rest: every settling object slower than this (m/s) and turning slower than REST_SPIN (rad/s)
REST_SPEED = 1e-3
REST_SPIN = 1e-2
#: a body let down without turning has its inertia times this
LOCKED = 1e6

Box = tuple[Vec3, Vec3]  # (min, max) corners of a bounding box, m, world frame


@dataclass(frozen=True)
class Placed:
    """A body for a settling: its shape (as built for the planning scene), pose and mass (kg; 0: static)."""

    shape: dict[str, Any]
    position: Sequence[float]
    orientation: Sequence[float]
    mass: float = 0.0


def settle(moving: Sequence[Placed], supports: Iterable[Placed],
           steps: int = SETTLE_STEPS) -> list[tuple[Vec3, Quat]]:
    """The poses (position m, quaternion xyzw) where ``moving`` come to rest on ``supports`` (static) and
    the floor plane z = 0, stepping PyBullet's physics until every one is at rest or ``steps`` steps have
    run (the poses then reached). First each is let down without turning (its inertia made huge: it lands
    as it was let go, not knocked over by the impact), then, from rest, with its own inertia (one hanging
    over an edge tips over)."""
    with Bullet() as b:
        b.add_floor()
        for s in supports:
            b.create_body(s.shape, s.position, s.orientation, 0.0)
        bodies = [b.create_body(m.shape, m.position, m.orientation, m.mass) for m in moving]
        inertias = [b.inertia(body) for body in bodies]
        for body, own in zip(bodies, inertias, strict=True):
            b.set_inertia(body, [LOCKED * max(own)] * 3)
        left = _until_rest(b, bodies, steps)
        for body, own in zip(bodies, inertias, strict=True):
            b.set_inertia(body, own)
        _until_rest(b, bodies, left)
        return [b.base_pose(body) for body in bodies]


def _until_rest(b: Bullet, bodies: Sequence[int], steps: int) -> int:
    """Steps until every body is at rest, at most ``steps``; the steps left."""
    for i in range(1, steps + 1):
        b.step()
        if i % CHECK_EVERY == 0 and all(_at_rest(b, body) for body in bodies):
            return steps - i
    return 0


def _at_rest(b: Bullet, body: int) -> bool:
    lin, ang = b.base_velocity(body)
    return sum(v * v for v in lin) < REST_SPEED**2 and sum(w * w for w in ang) < REST_SPIN**2


def in_column(moving: Sequence[Box], others: Iterable[tuple[Box, Placed]]) -> list[Placed]:
    """The bodies among ``others`` a settling of ``moving`` may meet: their boxes reach below the top of
    the moving ones and overlap, seen from above, the moving ones' boxes widened by their largest extent
    (an object may tip over)."""
    lo = [min(box[0][k] for box in moving) for k in range(3)]
    hi = [max(box[1][k] for box in moving) for k in range(3)]
    margin = max(box[1][k] - box[0][k] for box in moving for k in range(3))
    return [
        placed for (olo, ohi), placed in others
        if olo[2] < hi[2] and all(olo[k] < hi[k] + margin and ohi[k] > lo[k] - margin for k in (0, 1))
    ]


def lowest(placed: Placed) -> float | None:
    """The height (m) of a body's lowest point, from its shape and pose (None: a mesh read from its file,
    whose points we do not hold)."""
    p, rot = placed.position, quat_matrix(placed.orientation)
    s = placed.shape
    if s["type"] == "sphere":
        return float(p[2] - s["radius"])
    if s["type"] == "cylinder":  # its lowest end's rim
        up = float(rot[2, 2])
        return float(p[2] - abs(up) * s["length"] / 2 - s["radius"] * math.sqrt(max(0.0, 1 - up * up)))
    if s["type"] == "box":
        points = np.array(list(itertools.product(*[(-h / 2, h / 2) for h in s["size"]])))
    elif s.get(HULL) is not None:
        points = np.asarray(s[HULL], dtype=np.float64)
    else:
        return None
    return float(p[2] + (points @ rot.T)[:, 2].min())


def check_placed(bullet: Bullet, table: BodyTable, body: int, placed: Placed, *,
                 at_rest: bool = False, allow: int | None = None) -> None:
    """``Overlap`` naming the object ``body`` (``placed``) and the body it is put into: deeper than
    ``OVERLAP_TOLERANCE`` into any body or below the floor (placed), or touching a robot (``at_rest``:
    robots hold nothing up, and a robot's own verdicts count a touch as a contact). Body ``allow`` (the
    robot letting the object go) may touch it."""
    name = table.names[body]
    low = lowest(placed)
    if not at_rest and low is not None and -low > OVERLAP_TOLERANCE:
        raise Overlap(name, "floor (z = 0)", -low)
    bullet.detect()  # the broadphase's boxes follow the bodies just created or moved
    for other in sorted(bullet.bodies_near_links(body, [-1], 0.0)):
        if other not in table.names or other == allow or (at_rest and other not in table.robots):
            continue
        touching = [-c.distance for c in bullet.closest(body, other, 0.0) if c.distance <= 0.0]
        depth = max(touching, default=None)
        if depth is not None and (at_rest or depth > OVERLAP_TOLERANCE):
            raise Overlap(name, table.names[other], depth, at_rest=at_rest)
