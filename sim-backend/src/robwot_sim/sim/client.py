"""Typed wrapper of one PyBullet DIRECT client: pybullet tuples are unpacked into named types here."""

from __future__ import annotations

import contextlib
import functools
import json
import os
import sys
from collections.abc import Iterator, Sequence
from importlib import metadata
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pybullet as pb

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


#: the key of a read mesh shape holding its convex hull's scaled vertices (``scene_files.mesh_hull``)
HULL = "hull"

class JointInfo(NamedTuple):
    idx: int
    name: str
    type: int  # pb.JOINT_REVOLUTE / JOINT_PRISMATIC / JOINT_FIXED ...
    link_name: str
    parent_index: int
    axis: Vec3 = (0.0, 0.0, 1.0)  # in the joint (= child link) frame


class ContactPoint(NamedTuple):
    body_a: int
    body_b: int
    link_a: int
    link_b: int
    position_on_a: Vec3
    distance: float  # negative = penetration (m)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Send C-level stdout (Bullet's warnings) to stderr: stdout may carry a protocol (the ready line)."""
    sys.stdout.flush()
    try:
        saved = os.dup(1)
    except OSError:
        yield
        return
    try:
        os.dup2(2, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


#: where removed static bodies wait for reuse (m): far beyond any workspace
PARKING = 1.0e5


@functools.cache
def pybullet_version() -> str:
    """The installed PyBullet's version, read once per process (the package metadata is parsed from disk:
    a heartbeat's ``ping`` asks for it several times a second)."""
    try:
        return metadata.version("pybullet")
    except metadata.PackageNotFoundError:  # pragma: no cover - pybullet is a hard dependency
        return "unknown"


#: m: a contact point reporting its pair within this of touching is asked of again (``Recheck``): both
#: links' collision margins; a kept point reporting its pair farther apart is taken as apart (not proven:
#: the labels' order tests and ``bench:bounds``'s ``order`` column measure it)
RECHECK = 0.002


class Recheck:
    """Bullet's contact points of one robot body (``getContactPoints`` after a collision detection) checked
    against its pairs' own tests. Bullet keeps a pair's contact points from one detection to the next,
    refreshing their distances from the points' places on each link and the normal as first found: after
    another configuration a kept point may report a contact the pair's own test does not find (the xArm's
    gripper knuckles), or a touching pair a little apart (the Panda's fingers). So a point reported within
    ``RECHECK`` of the distance asked about is confirmed by a fresh test of its pair (``getClosestPoints``),
    and a verdict on a configuration does not depend on what was checked before it. Not where a link of
    the robot with a box shape reports a contact: Bullet finds the contacts of two boxes by another
    algorithm than their closest points (a carried cube just into a table may have none within 0), so
    such a contact stands as reported."""

    def __init__(self, cid: int, body: int) -> None:
        self.cid, self.body = cid, body
        shapes = {ln: pb.getCollisionShapeData(body, ln, physicsClientId=cid) or ()
                  for ln in range(-1, pb.getNumJoints(body, physicsClientId=cid))}
        self.boxes = frozenset(ln for ln, rows in shapes.items() if any(s[2] == pb.GEOM_BOX for s in rows))

    def stands(self, c: Any, within: float) -> bool:
        """Raw contact point ``c`` (bodies 1, 2, links 3, 4, distance 8) is taken as reported: a contact
        within ``within`` (m) of a link with a box shape."""
        return c[8] <= within and ((c[1] == self.body and c[3] in self.boxes)
                                   or (c[2] == self.body and c[4] in self.boxes))

    @staticmethod
    def asks(c: Any, within: float) -> bool:
        """Whether contact point ``c`` reports its pair within ``within`` (m) plus ``RECHECK``: one to ask
        about (``points``); a point farther is taken as apart."""
        return bool(c[8] <= within + RECHECK)

    def points(self, c: Any, within: float) -> list[Any]:
        """The raw points within ``within`` (m) of the pair of contact point ``c`` (one that ``asks``): ``c``
        itself where it ``stands``, else the pair's fresh test's."""
        if self.stands(c, within):
            return [c]
        fresh = pb.getClosestPoints(c[1], c[2], within, c[3], c[4], physicsClientId=self.cid)
        return [p for p in fresh if p[8] <= within]

    def touching(self, c: Any, within: float) -> bool:
        """Whether contact point ``c``'s pair is within ``within`` (m): ``asks`` and ``points``."""
        return self.asks(c, within) and bool(self.points(c, within))


class Bullet:
    """One PyBullet physics client in DIRECT mode. Use as a context manager or call ``close()``."""

    def __init__(self) -> None:
        self.cid: int = pb.connect(pb.DIRECT)
        if self.cid < 0:
            raise RuntimeError("could not start a PyBullet DIRECT client")
        # PyBullet never gives back the memory of a removed body (~3.5 KB each): removed static bodies
        # are parked far away, out of every check, and reused for the next obstacle of the same shape
        self._static_key: dict[int, str] = {}  # live static body -> its shape key
        self._parked: dict[str, list[int]] = {}  # shape key -> parked bodies
        self._invisible = -1  # the visual shape every created body shares (``invisible``)

    def close(self) -> None:
        if self.cid >= 0:
            pb.disconnect(physicsClientId=self.cid)
            self.cid = -1

    def __enter__(self) -> Bullet:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # bodies
    def load_urdf(self, path: str, position: Sequence[float], quat_xyzw: Sequence[float], flags: int) -> int:
        with stdout_to_stderr():
            return int(
                pb.loadURDF(
                    path,
                    list(position),
                    list(quat_xyzw),
                    useFixedBase=True,
                    flags=flags,
                    physicsClientId=self.cid,
                )
            )

    def remove_body(self, body: int) -> None:
        """Remove a body; a static body of ``create_static`` is parked for reuse instead (see __init__).
        Callers must forget a removed body: parked bodies are far away but still exist."""
        key = self._static_key.pop(body, None)
        if key is None:
            pb.removeBody(body, physicsClientId=self.cid)
            return
        parked = self._parked.setdefault(key, [])
        parked.append(body)
        far = PARKING + 10.0 * (len(self._static_key) + sum(len(v) for v in self._parked.values()))
        pb.resetBasePositionAndOrientation(body, [far, far, -far], [0, 0, 0, 1], physicsClientId=self.cid)

    def body_name(self, body: int) -> tuple[str, str]:
        """(base link name, body name)."""
        info = pb.getBodyInfo(body, physicsClientId=self.cid)
        return info[0].decode(), info[1].decode()

    def joints(self, body: int) -> list[JointInfo]:
        out = []
        for i in range(pb.getNumJoints(body, physicsClientId=self.cid)):
            ji = pb.getJointInfo(body, i, physicsClientId=self.cid)
            out.append(JointInfo(i, ji[1].decode(), int(ji[2]), ji[12].decode(), int(ji[16]), tuple(ji[13])))
        return out

    def reset_base(self, body: int, position: Sequence[float], quat_xyzw: Sequence[float]) -> None:
        pb.resetBasePositionAndOrientation(body, list(position), list(quat_xyzw), physicsClientId=self.cid)

    def base_pose(self, body: int) -> tuple[Vec3, Quat]:
        """The base's inertial frame (its centre of mass), as PyBullet keeps and resets it."""
        pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=self.cid)
        return tuple(pos), tuple(orn)

    def base_frame(self, body: int) -> tuple[Vec3, Quat]:
        """The base link's URDF frame: its inertial frame moved back by the link's inertial origin."""
        pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=self.cid)
        local_pos, local_orn = pb.getDynamicsInfo(body, -1, physicsClientId=self.cid)[3:5]
        inv_pos, inv_orn = pb.invertTransform(local_pos, local_orn)
        out_pos, out_orn = pb.multiplyTransforms(pos, orn, inv_pos, inv_orn)
        return tuple(out_pos), tuple(out_orn)

    def has_collision_shape(self, body: int, link: int) -> bool:
        return bool(pb.getCollisionShapeData(body, link, physicsClientId=self.cid))

    def link_box_corners(self, body: int, link: int) -> npt.NDArray[np.float64]:
        """The 8 corners (world, m) of a link's collision bounding box, which holds its shapes; ``(0, 3)``
        without collision shape."""
        if not self.has_collision_shape(body, link):
            return np.zeros((0, 3))
        lo, hi = pb.getAABB(body, link, physicsClientId=self.cid)
        return np.array([(x, y, z) for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])

    def link_masses(self, body: int, links: Sequence[int]) -> list[float]:
        return [float(pb.getDynamicsInfo(body, ln, physicsClientId=self.cid)[0]) for ln in links]

    # joints and kinematics
    def reset_joints(self, body: int, indices: Sequence[int], values: Sequence[float]) -> None:
        """Teleport joints (1-DoF each) to ``values`` with zero velocity."""
        pb.resetJointStatesMultiDof(body, indices, [[v] for v in values], physicsClientId=self.cid)

    def joint_positions(self, body: int, indices: Sequence[int]) -> list[float]:
        return [float(s[0]) for s in pb.getJointStates(body, list(indices), physicsClientId=self.cid)]

    def link_frame(self, body: int, link: int) -> tuple[Vec3, Quat]:
        """World pose of a link *frame* (not its centre of mass); link -1 is the base."""
        if link < 0:
            return self.base_frame(body)
        s = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=self.cid)
        return tuple(s[4]), tuple(s[5])

    def ik(
        self,
        body: int,
        link: int,
        position: Sequence[float],
        quat_xyzw: Sequence[float] | None,
        damping: Sequence[float],
        iterations: int,
        threshold: float,
    ) -> list[float]:
        """PyBullet damped least squares IK; one value per movable joint, starting from the current state."""
        kw: dict[str, Any] = {
            "jointDamping": list(damping),
            "maxNumIterations": iterations,
            "residualThreshold": threshold,
            "physicsClientId": self.cid,
        }
        if quat_xyzw is not None:
            kw["targetOrientation"] = list(quat_xyzw)
        return list(pb.calculateInverseKinematics(body, link, list(position), **kw))

    # collision
    def detect(self) -> None:
        pb.performCollisionDetection(physicsClientId=self.cid)

    def contacts(self, body_a: int, body_b: int = -1) -> list[ContactPoint]:
        """Contact points from the last ``detect()`` involving ``body_a`` (and ``body_b`` if given)."""
        if body_b >= 0:
            pts = pb.getContactPoints(body_a, body_b, physicsClientId=self.cid)
        else:
            pts = pb.getContactPoints(body_a, physicsClientId=self.cid)
        return [ContactPoint(c[1], c[2], c[3], c[4], tuple(c[5]), float(c[8])) for c in pts or ()]

    def contacts_raw(self, body_a: int) -> Any:
        """Raw contact tuples (fast path: index 3/4 links, 2 body b, 8 distance)."""
        return pb.getContactPoints(body_a, physicsClientId=self.cid)

    def bodies_near_links(self, body: int, links: Sequence[int], margin: float) -> set[int]:
        """Other bodies whose bounding boxes come within ``margin`` of the given links' boxes."""
        out: set[int] = set()
        for ln in links:
            lo, hi = pb.getAABB(body, ln, physicsClientId=self.cid)
            hits = pb.getOverlappingObjects([v - margin for v in lo], [v + margin for v in hi],
                                            physicsClientId=self.cid)
            out.update(b for b, _ in hits or () if b != body)
        return out

    def closest(
        self, body_a: int, body_b: int, distance: float, link_a: int | None = None, link_b: int | None = None
    ) -> list[ContactPoint]:
        kw: dict[str, Any] = {"physicsClientId": self.cid}
        if link_a is not None:
            kw["linkIndexA"] = link_a
        if link_b is not None:
            kw["linkIndexB"] = link_b
        pts = pb.getClosestPoints(body_a, body_b, distance, **kw)
        return [ContactPoint(c[1], c[2], c[3], c[4], tuple(c[5]), float(c[8])) for c in pts or ()]

    def set_pair_filter(self, body_a: int, body_b: int, link_a: int, link_b: int, enable: bool) -> None:
        pb.setCollisionFilterPair(body_a, body_b, link_a, link_b, int(enable), physicsClientId=self.cid)

    # static obstacles
    def create_static(
        self, shape: dict[str, Any], position: Sequence[float], quat_xyzw: Sequence[float]
    ) -> int:
        """A mass-0 body with one collision shape, no visual (``shape`` as in Contract 1, file resolved; a
        mesh with ``hull``: its convex hull's scaled vertices, the shape Bullet builds from the file)."""
        key = json.dumps({k: v for k, v in shape.items() if k != HULL}, sort_keys=True)
        parked = self._parked.get(key)
        if parked:
            body = parked.pop()
            self.reset_base(body, position, quat_xyzw)
            self._static_key[body] = key
            return body
        body = self.create_body(shape, position, quat_xyzw, 0.0)
        self._static_key[body] = key
        return body

    def invisible(self) -> int:
        """A visual shape for bodies made here (``create_body``): PyBullet gives a body without one a visual
        made from its collision shape, for a renderer nothing here uses (images are ray-cast against
        collision shapes, ``camera.py``), and tessellates spheres, cylinders and hulls to make it, which
        costs more than the body. A point-sized box, one per client, shared by every body, costs nothing
        to convert. Visual shapes take no part in collision detection or ray tests."""
        if self._invisible < 0:
            self._invisible = int(pb.createVisualShape(pb.GEOM_BOX, halfExtents=[1e-6] * 3,
                                                       physicsClientId=self.cid))
            if self._invisible < 0:
                raise RuntimeError("PyBullet could not create a visual shape")
        return self._invisible

    def create_body(
        self, shape: dict[str, Any], position: Sequence[float], quat_xyzw: Sequence[float], mass: float
    ) -> int:
        """A body of one collision shape (as ``create_static``) and ``mass`` (kg; 0: static), no visual
        (``invisible``); never parked. A mesh with mass is its convex hull to Bullet."""
        col = self._collision_shape(shape)
        return int(
            pb.createMultiBody(
                baseMass=mass,
                baseCollisionShapeIndex=col,
                baseVisualShapeIndex=self.invisible(),
                basePosition=list(position),
                baseOrientation=list(quat_xyzw),
                physicsClientId=self.cid,
            )
        )

    def _collision_shape(self, shape: dict[str, Any]) -> int:
        hull = shape.get(HULL)
        t = shape["type"]
        if t == "box":
            col = pb.createCollisionShape(
                pb.GEOM_BOX, halfExtents=[s / 2 for s in shape["size"]], physicsClientId=self.cid
            )
        elif t == "sphere":
            col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=shape["radius"], physicsClientId=self.cid)
        elif t == "cylinder":
            col = pb.createCollisionShape(
                pb.GEOM_CYLINDER, radius=shape["radius"], height=shape["length"], physicsClientId=self.cid
            )
        elif hull is not None:
            col = pb.createCollisionShape(pb.GEOM_MESH, vertices=hull, physicsClientId=self.cid)
        else:
            scale = shape.get("scale", 1.0)
            s3 = [scale] * 3 if isinstance(scale, (int, float)) else list(scale)
            with stdout_to_stderr():
                col = pb.createCollisionShape(
                    pb.GEOM_MESH, fileName=shape["file"], meshScale=s3, physicsClientId=self.cid
                )
            if col < 0:
                raise RuntimeError(f"PyBullet could not read the mesh {shape['file']}")
        if col < 0:
            raise RuntimeError(f"PyBullet could not create the collision shape {shape}")
        return int(col)

    # physics (settling objects: ``settle.py``, in a client of its own)
    def add_floor(self) -> int:
        """A static plane z = 0 (its normal +z), and gravity -9.81 m/s^2 along z."""
        pb.setGravity(0.0, 0.0, -9.81, physicsClientId=self.cid)
        col = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=self.cid)
        return int(pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=col, physicsClientId=self.cid))

    def step(self) -> None:
        pb.stepSimulation(physicsClientId=self.cid)

    def inertia(self, body: int) -> Vec3:
        """The diagonal of a body's base inertia (kg m^2, its inertial frame)."""
        return tuple(pb.getDynamicsInfo(body, -1, physicsClientId=self.cid)[2])

    def set_inertia(self, body: int, diagonal: Sequence[float]) -> None:
        pb.changeDynamics(body, -1, localInertiaDiagonal=list(diagonal), physicsClientId=self.cid)

    def base_velocity(self, body: int) -> tuple[Vec3, Vec3]:
        """(linear m/s, angular rad/s) of a body's base, world frame."""
        lin, ang = pb.getBaseVelocity(body, physicsClientId=self.cid)
        return tuple(lin), tuple(ang)

    def aabb(self, body: int, link: int = -1) -> tuple[Vec3, Vec3]:
        """(min, max) corners (m, world frame) of a body's (link's) bounding box."""
        lo, hi = pb.getAABB(body, link, physicsClientId=self.cid)
        return tuple(lo), tuple(hi)
