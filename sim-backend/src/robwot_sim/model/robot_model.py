"""The joint model of a loaded robot (Contract 1 ``RobotModel``): its links, joints and limits as the
contract reports them. Units: metres, radians, seconds; quaternions ``[x, y, z, w]``; world frame, Z up."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.limits import ACCELERATION_TIME, DEFAULT_CLEARANCE
from robwot_sim.model.couplings import Coupling, Followers
from robwot_sim.model.joints import JointInfo

FloatArray = npt.NDArray[np.float64]
#: the velocity limit (rad/s or m/s) of a joint whose URDF gives none (or a non-positive one)
DEFAULT_VELOCITY = 1.0


def _floats(v: Any) -> list[float]:
    return [float(x) for x in v]


@dataclass(frozen=True)
class Rates:
    """Limits on linear combinations of the joint velocities: ``|rows @ qdot| <= velocity`` and
    ``|rows @ qddot| <= acceleration``, one row per limited follower."""

    rows: FloatArray
    velocity: FloatArray
    acceleration: FloatArray

    def scaled(self, speed: float, acceleration: float) -> Rates:
        return Rates(self.rows, self.velocity * speed, self.acceleration * acceleration)


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
    #: joint -> jerk limit (rad/s^3 or m/s^3) of controllable joints (a joint_limits.yaml's ``max_jerk``);
    #: with any, every motion is jerk-limited (``motion.py``)
    jerks: dict[str, float] = field(default_factory=dict)
    #: the joints that follow others, in the controllable joints' coordinates (``model/couplings.py``)
    couplings: tuple[Coupling, ...] = ()

    def followers(self) -> Followers:
        """The joints that follow others, as arrays over the joint vector."""
        return Followers.of(self.controllable, self.couplings, self.joints)

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

    def jerk_limits(self) -> FloatArray:
        """Jerk limits (rad/s^3 or m/s^3) of the controllable joints, inf for a joint without one."""
        return np.array([self.jerks.get(n, math.inf) for n in self.controllable], dtype=np.float64)

    def follower_rates(self) -> Rates:
        """The followers with a velocity limit (a passive joint has none): their rows over the joint vector,
        velocity limits and acceleration limits (those of ``accelerations``, else reached from rest in
        ``ACCELERATION_TIME``)."""
        f = self.followers()
        keep = f.velocity > 0
        acc = np.array([self.accelerations.get(n, v / ACCELERATION_TIME) for n, v in zip(f.names, f.velocity,
                                                                                      strict=True)])
        return Rates(f.matrix[keep], f.velocity[keep], acc[keep] if len(acc) else acc)

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
            "couplings": [c.to_json() for c in self.couplings],
        }
