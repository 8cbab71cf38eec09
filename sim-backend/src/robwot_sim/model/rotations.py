"""Rotations in the URDF/ROS conventions: the one home of this maths in the backend.

Quaternions are ``[x, y, z, w]`` (scalar last); roll-pitch-yaw are fixed-axis angles in radians, the
rotation ``Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (URDF ``<origin rpy>``); matrices are 3x3 and rotate column
vectors from the child frame into the parent frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import pybullet as pb

FloatArray = npt.NDArray[np.float64]
Quat = tuple[float, float, float, float]


def rpy_matrix(roll: float, pitch: float, yaw: float) -> FloatArray:
    """URDF fixed-axis rotation ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]], dtype=np.float64)


def quat_matrix(quat_xyzw: Sequence[float]) -> FloatArray:
    """Rotation matrix of a quaternion ``[x, y, z, w]`` (normalised first)."""
    x, y, z, w = (float(v) for v in quat_xyzw)
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if n == 0.0:
        raise ValueError("zero quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]], dtype=np.float64)


def quat_from_rpy(rpy: Sequence[float]) -> Quat:
    """The quaternion ``[x, y, z, w]`` of fixed-axis roll-pitch-yaw (the rotation of ``rpy_matrix``), as
    Bullet computes it: bit for bit the orientation Bullet itself derives from the same angles, so a world
    rebuilt from its scene document equals the original."""
    q = pb.getQuaternionFromEuler([float(a) for a in rpy])
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def quat_angle(a: Sequence[float], b: Sequence[float]) -> float:
    """Rotation angle (rad) between two quaternions [x, y, z, w] (either sign of each)."""
    d = abs(sum(x * y for x, y in zip(a, b, strict=True)))
    na = math.sqrt(sum(x * x for x in a) * sum(y * y for y in b))
    return 2.0 * math.acos(min(1.0, d / na)) if na > 0 else math.pi


def quat_slerp(a: Sequence[float], b: Sequence[float], t: float) -> Quat:
    """The rotation a fraction ``t`` (0..1) of the way from ``a`` to ``b`` along the shorter arc, as a
    unit quaternion [x, y, z, w] (spherical linear interpolation)."""
    qa = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    qb = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    dot = float(qa @ qb)
    if dot < 0.0:  # the other sign of b is the shorter way
        qb, dot = -qb, -dot
    if dot > 0.9995:  # nearly equal: linear, normalised (sin of a tiny angle loses precision)
        q = qa + t * (qb - qa)
    else:
        theta = math.acos(dot)
        q = (math.sin((1 - t) * theta) * qa + math.sin(t * theta) * qb) / math.sin(theta)
    q = q / np.linalg.norm(q)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))
