"""Kinematics of the random-program bench's arms, and its independent check of LIN / CIRC refusals.

``Kin``: Pinocchio's model of the arm's tool URDF (the one ``robot.attachTool`` wrote) with FK / IK of its
``robwot_tcp`` frame, and Coal on the exact meshes (``ExactReference``) among the bench's boxes; none of the
backend's kinematics or collision code is used. ``program_random.py`` generates programs with it and
``program_bound.py`` takes the TCP positions of the time-optimal bound from it.

Refusals of LIN / CIRC steps are checked independently (``follow``): Pinocchio, damped least squares (lambda
1e-4, up to 100 iterations per point, 1e-5 m / 1e-4 rad) from the step's start configuration (the previous
step's reported ``target``) along the line (or the arc through the via point, the circle recomputed here)
in 0.5 mm steps (0.05 degree of slerped orientation at most), the orientation slerped; it "follows" when
every point converges within the joint limits and no joint moves more than ``JUMP`` rad between points (a
flip). Then the joint speed it needs at the step's ``tcpSpeed`` (``|dq_j| / step * tcpSpeed`` against
``v_j * speed``: the velocity ratio) and Coal along the followed configurations (every one for contact,
every fourth for the signed distance against the default 2 mm clearance) are reported. A false refusal:
refused, followed, velocity ratio <= 1, free by Coal with the clearance kept. (The velocity ratio of a path
not followed is that up to where it stops.) (DLS's step is the least-norm joint motion, so a velocity
ratio > 1 says the line needs the joints faster than allowed near there.)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_bench.reference import ExactReference

F = npt.NDArray[np.float64]
Vec = F | Sequence[float]
#: a box obstacle: (size, position), axis-aligned in the world frame
Box = tuple[tuple[float, float, float], tuple[float, float, float]]

#: m between the independent IK's points
IK_STEP = 0.0005
#: rad a joint may move between two IK points (0.5 mm) before it counts as a jump (a flip)
JUMP = 0.1



class Kin:
    """Pinocchio model of the tool URDF, FK / IK of its TCP frame, Coal via ``ExactReference``."""

    def __init__(self, urdf: Path, roots: dict[str, str], names: Sequence[str], srdf: Path | None,
                 obstacles: Sequence[Box]) -> None:
        import pinocchio as pin

        self.pin: Any = pin
        boxes = [(size, pos, (0.0, 0.0, 0.0, 1.0)) for size, pos in obstacles]
        self.ref = ExactReference(urdf, roots, names, srdf=srdf, obstacles=boxes)
        self.model = self.ref.model
        self.data = self.model.createData()
        self.fid = self.model.getFrameId("robwot_tcp")
        self.iq = [self.model.joints[self.model.getJointId(n)].idx_q for n in names]
        self.iv = [self.model.joints[self.model.getJointId(n)].idx_v for n in names]

    def _q(self, q: Vec) -> F:
        return self.ref.configuration([float(v) for v in q])

    def fk(self, q: Vec) -> tuple[F, F]:
        pin = self.pin
        pin.framesForwardKinematics(self.model, self.data, self._q(q))
        m = self.data.oMf[self.fid]
        return np.array(m.translation), np.array(m.rotation)

    def quat(self, rot: F) -> list[float]:
        c = self.pin.Quaternion(rot).coeffs()  # x, y, z, w
        return [float(v) for v in c]

    def jacobian(self, q: Vec) -> F:
        pin = self.pin
        pin.computeJointJacobians(self.model, self.data, self._q(q))
        pin.framesForwardKinematics(self.model, self.data, self._q(q))
        j = pin.getFrameJacobian(self.model, self.data, self.fid, pin.LOCAL_WORLD_ALIGNED)
        return np.asarray(j)[:, self.iv]

    def solve(self, q0: F, p: F, rot: F, lo: F, hi: F) -> tuple[F | None, str]:
        """Damped least squares from ``q0`` to the pose: the configuration, or None and why not."""
        pin = self.pin
        q = q0.copy()
        for _ in range(100):
            pos, r = self.fk(q)
            e = np.concatenate([p - pos, pin.log3(rot @ r.T)])
            if np.linalg.norm(e[:3]) < 1e-5 and np.linalg.norm(e[3:]) < 1e-4:
                if bool(np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9)):
                    return q, ""
                return None, "leaves the joint limits"
            jac = self.jacobian(q)
            dq = jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(6), e)
            q = q + dq
        return None, "IK does not converge"

    def clear(self, q: Vec, margin: float) -> bool:
        return self.ref.min_signed_distance([float(v) for v in q]) > margin

    def path_free(self, a: F, b: F, step: float = 0.02) -> bool:
        n = max(2, math.ceil(float(np.abs(b - a).max()) / step) + 1)
        qs = np.linspace(a, b, n)
        return bool(self.ref.collision_free(qs).all())


def slerp(r0: F, r1: F, s: float, pin: Any) -> F:
    out: F = r0 @ pin.exp3(s * pin.log3(r0.T @ r1))
    return out


def circle(a: F, b: F, c: F) -> Callable[[float], F] | None:
    """The arc from ``a`` through ``b`` to ``c`` as a function of s in [0, 1], and None on one line."""
    ab, ac = b - a, c - a
    n = np.cross(ab, ac)
    nn = float(n @ n)
    if nn < 1e-12:
        return None
    centre = a + (np.cross(n, ab) * (ac @ ac) + np.cross(ac, n) * (ab @ ab)) / (2 * nn)
    e1 = (a - centre) / np.linalg.norm(a - centre)
    e2 = np.cross(n / math.sqrt(nn), e1)
    radius = float(np.linalg.norm(a - centre))

    def ang(x: F) -> float:
        d = x - centre
        return float(np.arctan2(d @ e2, d @ e1)) % (2 * math.pi)

    sweep = ang(c)

    def at(s: float) -> F:
        t = s * sweep
        out: F = centre + radius * (math.cos(t) * e1 + math.sin(t) * e2)
        return out

    return at


@dataclass
class Follow:
    followed: bool
    why: str
    velocity_ratio: float = 0.0
    coal_free: bool = False
    min_distance: float = float("nan")


def follow(kin: Kin, q0: F, step: dict[str, Any], lo: F, hi: F, vlim: F) -> Follow:
    """The independent check of a LIN or CIRC from ``q0`` (see the module docstring)."""
    p0, r0 = kin.fk(q0)
    p1 = np.asarray(step["position"], dtype=np.float64)
    if "orientation" in step:
        x, y, z, w = step["orientation"]
        r1 = np.asarray(kin.pin.Quaternion(w, x, y, z).normalized().matrix())
    else:
        r1 = r0
    if step.get("motion") == "circ":
        arc = circle(p0, np.asarray(step["via"], dtype=np.float64), p1)
        if arc is None:
            return Follow(False, "start, via and target on one line")
        pts = np.array([arc(s) for s in np.linspace(0, 1, 2001)])
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        point = arc
    else:
        length = float(np.linalg.norm(p1 - p0))

        def point(s: float) -> F:
            out: F = p0 + s * (p1 - p0)
            return out
    turn = float(np.linalg.norm(kin.pin.log3(r0.T @ r1)))
    n = max(1, math.ceil(length / IK_STEP), math.ceil(turn / math.radians(0.05)))
    qs = [q0]
    speed = float(step.get("speed", 1.0))
    tcp = float(step.get("tcpSpeed", 0.25))
    ratio = 0.0
    for i in range(1, n + 1):
        s = i / n
        q, why = kin.solve(qs[-1], point(s), slerp(r0, r1, s, kin.pin), lo, hi)
        if q is None:
            return Follow(False, f"{why} {1000 * s * length:.1f} mm along", ratio)
        dq = np.abs(q - qs[-1])
        if dq.max() > JUMP:
            return Follow(False, f"joint jump {dq.max():.3f} rad at {1000 * s * length:.1f} mm", ratio)
        if length > 0:
            ratio = max(ratio, float((dq / (length / n) * tcp / (vlim * speed)).max()))
        qs.append(q)
    arr = np.asarray(qs)
    free = bool(kin.ref.collision_free(arr).all())
    dist = min(kin.ref.min_signed_distance([float(v) for v in q]) for q in arr[::4]) if free else float("nan")
    return Follow(True, "followed", ratio, free, dist)

