"""A second, collision-only PyBullet client for batches of collision checks.

Bullet's ``performCollisionDetection`` updates the bounding box of every object and manages the
broadphase pairs of all of them at every call: with hundreds of static obstacles this overhead rivals
the narrowphase itself. Here all primitive obstacles (box, sphere, cylinder) are merged into ONE compound
body, whose internal AABB tree finds the children near each robot link; robots are mirrored (same
URDF, base pose, self-collision filter) and mesh obstacles stay separate bodies. Only collision-free
flags come out of this client; contact details come from the main world (``CollisionChecker``).
The mirror is rebuilt when the world changes (``BodyTable.version``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

from robwot_sim.model.couplings import Followers
from robwot_sim.model.urdf import prepare_urdf
from robwot_sim.sim.client import Bullet, Recheck
from robwot_sim.sim.types import FloatArray

TOUCH = 0.0
MAX_CHILDREN = 16
BIG = 0.3  # m: obstacles larger than this are not merged


def _clusters(items: list[dict[str, Any]], size: int) -> list[list[dict[str, Any]]]:
    """Spatially compact groups of at most ``size`` obstacles (PyBullet caps a compound at 16 children):
    recursive median splits along the widest axis, so each compound has a small bounding box."""
    if len(items) <= size:
        return [items] if items else []
    pts = np.array([o["position"] for o in items], dtype=np.float64)
    axis = int(np.argmax(pts.max(axis=0) - pts.min(axis=0)))
    order = np.argsort(pts[:, axis], kind="stable")
    half = len(items) // 2
    return _clusters([items[i] for i in order[:half]], size) + _clusters(
        [items[i] for i in order[half:]], size
    )


def _extent(shape: dict[str, Any]) -> float:
    """Largest dimension of a primitive shape (m); inf for meshes."""
    t = shape["type"]
    if t == "box":
        return float(max(shape["size"]))
    if t == "sphere":
        return 2 * float(shape["radius"])
    if t == "cylinder":
        return max(2 * float(shape["radius"]), float(shape["length"]))
    return float("inf")


@dataclass
class MirrorRobot:
    """What the mirror needs to rebuild a robot."""

    urdf: Path
    package_roots: Mapping[str, str]
    base_position: tuple[float, float, float]
    base_orientation: tuple[float, float, float, float]
    set_idx: list[int]
    filtered: set[tuple[int, int]]


class FastWorld:
    """Mirror of a world for ``is_free`` batches; build with ``FastWorld(robots, obstacles, version)``."""

    def __init__(
        self, robots: Mapping[str, MirrorRobot], obstacles: list[dict[str, Any]], version: int
    ) -> None:
        self.version = version
        self.bullet = Bullet()
        self.bodies: dict[str, int] = {}
        self.recheck: dict[str, Recheck] = {}
        try:
            for rid, r in robots.items():
                prepared = prepare_urdf(r.urdf, r.package_roots)
                try:
                    body = self.bullet.load_urdf(
                        str(prepared.bullet_path),
                        r.base_position,
                        r.base_orientation,
                        pb.URDF_USE_SELF_COLLISION,
                    )
                finally:
                    prepared.cleanup()
                for a, b in r.filtered:
                    self.bullet.set_pair_filter(body, body, a, b, False)
                self.bodies[rid] = body
                self.recheck[rid] = Recheck(self.bullet.cid, body)
            self._add_obstacles(obstacles)
        except Exception:
            self.bullet.close()
            raise
        self.robots = dict(robots)

    def _add_obstacles(self, obstacles: list[dict[str, Any]]) -> None:
        # big obstacles (a table) stay single bodies: inside a compound they would widen its bounding box
        prims = [o for o in obstacles if o["shape"]["type"] != "mesh" and _extent(o["shape"]) <= BIG]
        for o in obstacles:
            if o["shape"]["type"] == "mesh" or _extent(o["shape"]) > BIG:
                self.bullet.create_static(o["shape"], o["position"], o["orientation"])
        for group in _clusters(prims, MAX_CHILDREN):
            self._compound(group)

    def _compound(self, prims: list[dict[str, Any]]) -> None:
        cid = self.bullet.cid
        types, radii, halves, lengths = [], [], [], []
        for o in prims:
            s = o["shape"]
            t = s["type"]
            types.append({"box": pb.GEOM_BOX, "sphere": pb.GEOM_SPHERE, "cylinder": pb.GEOM_CYLINDER}[t])
            radii.append(float(s.get("radius", 0.0)))
            halves.append([v / 2 for v in s["size"]] if t == "box" else [0.0, 0.0, 0.0])
            lengths.append(float(s.get("length", 0.0)))
        col = pb.createCollisionShapeArray(
            shapeTypes=types,
            radii=radii,
            halfExtents=halves,
            lengths=lengths,
            collisionFramePositions=[o["position"] for o in prims],
            collisionFrameOrientations=[o["orientation"] for o in prims],
            physicsClientId=cid,
        )
        if col < 0:
            raise RuntimeError("PyBullet could not create the compound obstacle shape")
        body = pb.createMultiBody(
            baseMass=0, baseCollisionShapeIndex=col, baseVisualShapeIndex=self.bullet.invisible(),
            physicsClientId=cid
        )
        if len(pb.getCollisionShapeData(body, -1, physicsClientId=cid) or ()) != len(prims):
            raise RuntimeError("PyBullet dropped children of a compound obstacle shape")

    def close(self) -> None:
        self.bullet.close()

    def batch(
        self,
        robot_id: str,
        qs: FloatArray,
        others: Mapping[str, list[float]],
        followers: Followers,
    ) -> np.ndarray:
        """Collision-free flag per row of ``qs`` for ``robot_id``; ``others`` gives robots' states as full
        value lists for their ``set_idx`` (``robot_id``'s own too: the batch starts by a test there, as
        ``CollisionChecker.batch``); a contact point within ``RECHECK`` of touching is confirmed by its
        pair's own test (``Recheck``), so a row's flag does not depend on the rows before it."""
        b, cid = self.bullet, self.bullet.cid
        for rid, vals in others.items():
            b.reset_joints(self.bodies[rid], self.robots[rid].set_idx, list(vals))
        b.detect()
        body = self.bodies[robot_id]
        r = self.robots[robot_id]
        idx, filtered, recheck = r.set_idx, r.filtered, self.recheck[robot_id]
        out = np.zeros(len(qs), dtype=bool)
        reset, detect, contacts = (
            pb.resetJointStatesMultiDof,
            pb.performCollisionDetection,
            pb.getContactPoints,
        )
        full = np.asarray(qs, dtype=np.float64)
        if len(followers):
            full = np.hstack([full, followers.values(full)])
        # [[v], [v], ...] per row from one flat tolist (20,000 kuka rows, reset included: 7.0-7.4 us a row;
        # a nested tolist of (n, dof, 1) 8.3-10.2 us, one resetJointState per joint 25 us)
        for i, row in enumerate(full.tolist()):
            reset(body, idx, [[v] for v in row], physicsClientId=cid)
            detect(physicsClientId=cid)
            free = True
            for c in contacts(body, physicsClientId=cid):
                if ((c[1] != c[2] or (min(c[3], c[4]), max(c[3], c[4])) not in filtered)
                        and recheck.touching(c, TOUCH)):
                    free = False
                    break
            out[i] = free
        return out
