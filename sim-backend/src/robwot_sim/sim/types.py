"""Value types returned by the simulation core (frozen dataclasses with ``to_json()``).

Units: metres, radians, seconds. Quaternions are ``[x, y, z, w]``. Frames: world frame, Z up.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


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
    #: the contacts of the path's first state when it starts in contact (``exit_contact.py``): a path
    #: refused for them is refused because the current state collides
    start_contacts: tuple[Contact, ...] = ()

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "collisionFree": self.collision_free,
            "duration": self.duration,
            "steps": self.steps,
        }
        if self.first_collision is not None:
            out["firstCollision"] = self.first_collision.to_json()
        return out
