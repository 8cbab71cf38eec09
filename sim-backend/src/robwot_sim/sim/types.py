"""Value types returned by the simulation core (frozen dataclasses with ``to_json()``).

Units: metres, radians, seconds. Quaternions are ``[x, y, z, w]``. Frames: world frame, Z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.limits import ACCELERATION_TIME, DEFAULT_CLEARANCE
from robwot_sim.model.joints import JointInfo

FloatArray = npt.NDArray[np.float64]
DEFAULT_VELOCITY = 1.0


def _floats(v: Any) -> list[float]:
    return [float(x) for x in v]


@dataclass(frozen=True)
class Pose:
    """A link frame pose in the world frame: position (m) and quaternion ``[x, y, z, w]``."""

    position: tuple[float, float, float]
    quat_xyzw: tuple[float, float, float, float]
    link: str = ""

    def to_json(self) -> dict[str, Any]:
        return {"position": _floats(self.position), "orientation": _floats(self.quat_xyzw), "link": self.link}


@dataclass(frozen=True)
class IkResult:
    """An IK solution (controllable joint order), residual position error (m) and orientation error (rad)."""

    positions: tuple[float, ...]
    position_error: float
    orientation_error: float
    collision_free: bool

    def to_json(self) -> dict[str, Any]:
        return {
            "positions": _floats(self.positions),
            "positionError": self.position_error,
            "orientationError": self.orientation_error,
            "collisionFree": self.collision_free,
        }


@dataclass(frozen=True)
class BodyLink:
    """One side of a contact: a robot id or obstacle name, and a link name (``None`` for base/obstacle)."""

    body: str
    link: str | None

    def to_json(self) -> dict[str, Any]:
        return {"body": self.body, "link": self.link}


@dataclass(frozen=True)
class Contact:
    """A contact pair with its penetration depth (m, >= 0) and world position of the contact on ``a``."""

    a: BodyLink
    b: BodyLink
    depth: float
    position: tuple[float, float, float]

    def to_json(self) -> dict[str, Any]:
        return {
            "a": self.a.to_json(),
            "b": self.b.to_json(),
            "depth": self.depth,
            "position": _floats(self.position),
        }


@dataclass(frozen=True)
class CollisionReport:
    collision_free: bool
    contacts: tuple[Contact, ...] = ()

    def to_json(self) -> dict[str, Any]:
        return {"collisionFree": self.collision_free, "contacts": [c.to_json() for c in self.contacts]}


@dataclass(frozen=True)
class FirstCollision:
    time: float
    positions: tuple[float, ...]
    contacts: tuple[Contact, ...]

    def to_json(self) -> dict[str, Any]:
        return {
            "time": self.time,
            "positions": _floats(self.positions),
            "contacts": [c.to_json() for c in self.contacts],
        }


@dataclass(frozen=True)
class PathReport:
    """Result of checking a planned path step by step (``duration`` in s, ``steps`` states incl. start)."""

    collision_free: bool
    duration: float
    steps: int
    first_collision: FirstCollision | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "collisionFree": self.collision_free,
            "duration": self.duration,
            "steps": self.steps,
        }
        if self.first_collision is not None:
            out["firstCollision"] = self.first_collision.to_json()
        return out


@dataclass(frozen=True)
class RobotModel:
    """The joint model of a loaded robot (Contract 1 ``RobotModel``)."""

    id: str
    name: str
    urdf: str
    ee_link: str
    links: tuple[str, ...]
    joints: tuple[JointInfo, ...]
    controllable: tuple[str, ...]
    filtered_pairs: tuple[tuple[str, str], ...]
    base_position: tuple[float, float, float]
    base_orientation: tuple[float, float, float, float]
    package_roots: dict[str, str] = field(default_factory=dict)
    #: the SRDF whose ``<disable_collisions>`` pairs are in ``filtered_pairs`` (absolute path), if any
    srdf: str | None = None
    #: clearance (m) its paths and motions keep to other bodies
    clearance: float = DEFAULT_CLEARANCE
    #: joint -> acceleration limit (rad/s^2 or m/s^2) from a joint_limits.yaml (see acceleration_limits)
    accelerations: dict[str, float] = field(default_factory=dict)

    @property
    def dof(self) -> int:
        return len(self.controllable)

    def joint(self, name: str) -> JointInfo:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    def limits(self) -> tuple[FloatArray, FloatArray]:
        """Lower and upper limits of the controllable joints, in vector order."""
        js = [self.joint(n) for n in self.controllable]
        return (
            np.array([j.lower for j in js], dtype=np.float64),
            np.array([j.upper for j in js], dtype=np.float64),
        )

    def velocity_limits(self) -> FloatArray:
        """Velocity limits (rad/s or m/s) of the controllable joints.

        A missing or non-positive URDF velocity limit is taken as ``DEFAULT_VELOCITY`` (1 rad/s or m/s).
        """
        v = [self.joint(n).velocity for n in self.controllable]
        return np.array([x if x > 0 and math.isfinite(x) else DEFAULT_VELOCITY for x in v], dtype=np.float64)

    def acceleration_limits(self) -> FloatArray:
        """Acceleration limits (rad/s^2 or m/s^2) of the controllable joints: those of ``accelerations``;
        a joint without one reaches its velocity limit from rest in ``ACCELERATION_TIME``."""
        v = self.velocity_limits()
        return np.array([self.accelerations.get(n, v[i] / ACCELERATION_TIME)
                         for i, n in enumerate(self.controllable)], dtype=np.float64)

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "name": self.name,
            "urdf": self.urdf,
            "eeLink": self.ee_link,
            "links": list(self.links),
            "joints": [j.to_json() for j in self.joints],
            "controllable": list(self.controllable),
            "filteredPairs": [list(p) for p in self.filtered_pairs],
            "basePosition": _floats(self.base_position),
            "baseOrientation": _floats(self.base_orientation),
            **({"srdf": self.srdf} if self.srdf else {}),
            "clearance": self.clearance,
        }
