"""An independent collision reference for measuring the twin's verdicts: Pinocchio + Coal.

Coal checks the robots' own collision meshes exactly (BVH of the non-convex triangles), with none of
PyBullet's convex hulls. Pairs of geometries on the same rigid body (links joined by fixed joints) or on
adjacent bodies (joined by one joint) are not checked: they touch at their joint by design, and every
tool (PyBullet's self-collision, MoveIt's "Adjacent" SRDF entries) leaves them out too. With an SRDF its
``<disable_collisions>`` pairs are removed as well.

A contact Coal reports between two checked geometries is a collision unless both its penetration depth
and the pair's signed distance stay within ``TOUCH`` of zero: surfaces resting on each other, as closed
gripper fingers do. Both figures are needed: Coal reports a depth of 0 for most contacts between two
non-convex meshes whatever the overlap (their signed distance then says tens of millimetres), and a
signed distance of 0 for some deep ones (their depth then says so). A depth threshold alone called
interpenetrating configurations free, so the reference could not catch a part that no longer covers
its mesh.

A carried object (MoveIt's attached collision object) is a box fixed to a frame of the robot
(``attach_box``), checked against the obstacles and the robot's geometries but those of the hand holding it.
With ``mimic`` set, a joint with a URDF ``<mimic>`` tag follows its leader (Pinocchio reads it as an
independent joint, left at 0: a Panda's right finger closed whatever the left one does). Every query
starts Coal's GJK from its default guess, never from the pair's previous query (``_geometry_data``).

Needs the ``dev`` extra (``pin``, ``example-robot-data``); used by tests and ``fidelity.py``, never by the
twin itself.
"""

from __future__ import annotations

import sys
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

#: surfaces closer than this (m) in depth and in signed distance touch: a contact, not a collision
TOUCH = 5e-5


def example_robot_data() -> Path:
    """The ``share/example-robot-data`` folder of the ``example-robot-data`` wheel."""
    for base in [Path(p) for p in sys.path] + [Path(sys.prefix)]:
        for cand in (base / "cmeel.prefix/share/example-robot-data",
                     base / "lib/python3.11/site-packages/cmeel.prefix/share/example-robot-data"):
            if (cand / "robots").is_dir():
                return cand
    raise FileNotFoundError("example-robot-data is not installed (pip install example-robot-data)")


@dataclass(frozen=True)
class ExampleRobot:
    """A robot of example-robot-data as published for ROS/MoveIt: URDF with mesh collision geometry."""

    name: str
    urdf: Path
    srdf: Path | None
    package_roots: dict[str, str]


def example_robot(name: str) -> ExampleRobot:
    """``ur10``, ``ur5``, ``ur3``, ``panda``, ``z1``, ``xarm7`` or ``kinova`` (Jaco 2, COLLADA collision
    meshes) from example-robot-data (``package://example-robot-data/...``)."""
    root = example_robot_data()
    files = {
        "ur10": ("ur_description/urdf/ur10_robot.urdf", None),
        "ur5": ("ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf"),
        "ur3": ("ur_description/urdf/ur3_robot.urdf", None),
        "panda": ("panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf"),
        "z1": ("z1_description/urdf/z1.urdf", "z1_description/srdf/z1.srdf"),
        "xarm7": ("xarm_description/urdf/xarm7.urdf", None),
        "kinova": ("kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf"),
    }
    urdf, srdf = files[name]
    return ExampleRobot(name, root / "robots" / urdf, root / "robots" / srdf if srdf else None,
                        {"example-robot-data": str(root)})


class ExactReference:
    """Self-collision of one robot on its exact meshes, for joint vectors in the twin's joint order, and its
    contacts with fixed boxes (``obstacles``: size, position, quaternion xyzw in the robot's base frame),
    which every geometry of a moving link is checked against. ``mimic``: joints with a URDF ``<mimic>`` tag
    follow their leader (else they stay at 0)."""

    def __init__(self, urdf: Path, package_roots: dict[str, str], joint_names: Sequence[str],
                 srdf: Path | None = None,
                 obstacles: Sequence[tuple[Sequence[float], Sequence[float], Sequence[float]]] = (),
                 mimic: bool = False) -> None:
        import pinocchio as pin

        self._pin = pin
        roots = list(package_roots.values())
        dirs = [str(urdf.parent), *roots, *(str(Path(d).parent) for d in roots)]
        self.model, self.geometry, _ = pin.buildModelsFromUrdf(str(urdf), package_dirs=dirs)
        self.geometry.addAllCollisionPairs()
        parents = self.model.parents
        for k in reversed(range(len(self.geometry.collisionPairs))):
            pair = self.geometry.collisionPairs[k]
            a = self.geometry.geometryObjects[pair.first].parentJoint
            b = self.geometry.geometryObjects[pair.second].parentJoint
            if a == b or parents[a] == b or parents[b] == a:
                self.geometry.removeCollisionPair(pair)
        if srdf is not None:
            pin.removeCollisionPairs(self.model, self.geometry, str(srdf))
        self._add_boxes(obstacles)
        self.pairs = len(self.geometry.collisionPairs)
        self._data = self.model.createData()
        self._gdata = self._geometry_data()
        self._slots: list[tuple[int, int]] = []
        for name in joint_names:
            joint = self.model.joints[self.model.getJointId(name)]
            self._slots.append((joint.idx_q, joint.nq))
        #: (follower's q index, leader's position in ``joint_names``, multiplier, offset)
        self._mimics: list[tuple[int, int, float, float]] = []
        if mimic:
            self._mimics = self._mimic_slots(urdf, list(joint_names))
        self._attached = 0

    def _mimic_slots(self, urdf: Path, names: list[str]) -> list[tuple[int, int, float, float]]:
        out = []
        for el in ET.parse(urdf).getroot().iter("joint"):
            tag = el.find("mimic")
            name = el.get("name")
            if tag is None or name is None or not self.model.existJointName(name):
                continue
            leader = tag.get("joint")
            if leader not in names:
                raise ValueError(f"joint {name!r} mimics {leader!r}, which is not among the joints given")
            joint = self.model.joints[self.model.getJointId(name)]
            if joint.nq != 1:
                raise ValueError(f"mimic joint {name!r} is not a one-coordinate joint")
            out.append((joint.idx_q, names.index(leader), float(tag.get("multiplier", "1")),
                        float(tag.get("offset", "0"))))
        return out

    def attach_box(self, frame: str, size: Sequence[float], position: Sequence[float],
                   quat_xyzw: Sequence[float], ignore: Collection[str] = ()) -> None:
        """A box (a carried object) fixed to ``frame`` (a link or frame of the model) at ``position``,
        ``quat_xyzw`` in that frame, checked against the obstacles and every geometry of the robot but
        those of the links named in ``ignore`` (the hand holding it), whatever joints lie between."""
        import coal

        pin: Any = self._pin
        fid = self.model.getFrameId(frame)
        if fid >= len(self.model.frames):
            raise ValueError(f"no frame {frame!r} in the model")
        f = self.model.frames[fid]
        x, y, z, w = (float(v) for v in quat_xyzw)
        offset = pin.SE3(pin.Quaternion(w, x, y, z).matrix(), np.asarray(position, dtype=np.float64))
        box = pin.GeometryObject(f"attached_{self._attached}", f.parentJoint, fid, f.placement * offset,
                                 coal.Box(*(float(s) for s in size)))
        self._attached += 1
        frames = self.model.frames
        # an obstacle's parentFrame is unset (no frame of the model): never a link of the hand
        others = [i for i, g in enumerate(self.geometry.geometryObjects)
                  if not (g.parentFrame < len(frames) and frames[g.parentFrame].name in ignore)]
        gid = self.geometry.addGeometryObject(box)
        for g in others:
            self.geometry.addCollisionPair(pin.CollisionPair(g, gid))
        self.pairs = len(self.geometry.collisionPairs)
        self._gdata = self._geometry_data()

    def _geometry_data(self) -> Any:
        """Pinocchio's per-pair state, each query starting GJK from Coal's default guess: Pinocchio
        enables the guess cached from the pair's previous query, and from a stale one GJK called a 5 cm
        box 1 cm deep into another's top face free (after a query with them 25 cm apart; free or not
        then depended on what was checked before)."""
        pin: Any = self._pin
        gdata = pin.GeometryData(self.geometry)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # the flag is deprecated, and still read
            for request in [*gdata.collisionRequests, *gdata.distanceRequests]:
                request.enable_cached_gjk_guess = False
        return gdata

    def _add_boxes(self, boxes: Sequence[tuple[Sequence[float], Sequence[float], Sequence[float]]]) -> None:
        import coal

        pin: Any = self._pin
        moving = [i for i, g in enumerate(self.geometry.geometryObjects) if g.parentJoint != 0]
        for k, (size, position, (x, y, z, w)) in enumerate(boxes):
            placement = pin.SE3(pin.Quaternion(w, x, y, z).matrix(), np.asarray(position, dtype=np.float64))
            box = pin.GeometryObject(f"obstacle_{k}", 0, placement, coal.Box(*(float(s) for s in size)))
            gid = self.geometry.addGeometryObject(box)
            for g in moving:
                self.geometry.addCollisionPair(pin.CollisionPair(g, gid))

    def configuration(self, q: Sequence[float]) -> npt.NDArray[np.float64]:
        """Pinocchio's q for a twin joint vector (continuous joints as cos, sin)."""
        out: npt.NDArray[np.float64] = self._pin.neutral(self.model)
        for (idx, nq), v in zip(self._slots, q, strict=True):
            if nq == 2:
                out[idx:idx + 2] = (np.cos(v), np.sin(v))
            else:
                out[idx] = v
        for idx, leader, multiplier, offset in self._mimics:
            out[idx] = multiplier * q[leader] + offset
        return out

    def collision_free(self, qs: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        """Collision-free flag per row of ``qs`` [n, dof]: False when a checked pair is in contact beyond
        touching (see the module docstring)."""
        pin: Any = self._pin
        out = np.ones(len(qs), dtype=bool)
        for i, q in enumerate(qs):
            config = self.configuration(q)
            if not pin.computeCollisions(self.model, self._data, self.geometry, self._gdata, config, False):
                continue
            touching = []
            for k, result in enumerate(self._gdata.collisionResults):
                if not result.isCollision():
                    continue
                if any(abs(c.penetration_depth) > TOUCH for c in result.getContacts()):
                    out[i] = False
                    break
                touching.append(k)
            else:
                pin.computeDistances(self.model, self._data, self.geometry, self._gdata, config)
                out[i] = all(self._gdata.distanceResults[k].min_distance >= -TOUCH for k in touching)
        return out

    def min_signed_distance(self, q: Sequence[float]) -> float:
        """The smallest signed distance (m) between checked geometries at ``q`` (negative: they overlap)."""
        pin: Any = self._pin
        pin.computeDistances(self.model, self._data, self.geometry, self._gdata, self.configuration(q))
        return float(min(r.min_distance for r in self._gdata.distanceResults))
