"""IK of a robot of a scene, as a request asks it: the solver (``kinematics.solve_ik``) run with the robot
held (``Scene.holding``), collision-free by the scene's checker, its random restarts seeded from the request
itself, the robot's state unchanged."""

from __future__ import annotations

import functools
import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from robwot_sim import validate as v
from robwot_sim.model.chain_ik import smallest_singular_value, track_chain_ik
from robwot_sim.model.fk import ChainFK
from robwot_sim.sim.kinematics import solve_ik
from robwot_sim.sim.planning_scene import Quat, Scene, Vec3
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import IkResult

#: the smallest singular value of the end link's Jacobian (m/rad, rad/rad) below which a pose is taken as
#: singular: a 5 mm step of the end link there needs more than a quarter radian of some joint
SINGULAR = 0.02
#: how close (rad or m) to a limit a joint counts as at it
AT_LIMIT = 1e-6


def request_rng(salt: int, *parts: Sequence[float] | npt.NDArray[np.float64] | None) -> np.random.Generator:
    """IK restarts seeded from the request itself (state, target, orientation): the same question always
    gets the same answer, so a target validated as reachable and collision-free is solved the same way
    when the move follows; different requests still get independent restarts."""
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        h.update(b"-" if p is None else np.ascontiguousarray(p, dtype=np.float64).tobytes())
    return np.random.default_rng([salt, *np.frombuffer(h.digest(), dtype=np.uint32).tolist()])


def _seed(b: BoundRobot, seed: Sequence[float]) -> npt.NDArray[np.float64]:
    """A seed checked: a first guess, so a gripper's pinned joints are taken where they are."""
    try:
        guess: object = b.pin(np.asarray(seed, dtype=np.float64))
    except (TypeError, ValueError, IndexError):
        guess = seed  # not a joint vector: ``validate`` says what is wrong with it
    return b.validate(guess, "seed")


def ik(scene: Scene, robot_id: str, position: Vec3, quat_xyzw: Quat | None = None,
       seed: Sequence[float] | None = None, collision_free: bool = True, *, salt: int = 0) -> IkResult:
    """Joint positions putting the end-effector frame at ``position`` (+ ``quat_xyzw``), from ``seed``
    (default: the current state); ``salt`` salts the restarts' seeds. Read-only."""
    e = scene.entry(robot_id)
    b = e.bound
    pos = v.position("position", position)
    quat = None if quat_xyzw is None else v.quaternion("orientation", quat_xyzw)
    start = b.q.copy() if seed is None else _seed(b, seed)
    want_free = v.flag("collisionFree", collision_free)
    saved = b.q.copy()

    def is_free(q: npt.NDArray[np.float64]) -> bool:
        b.apply(q)
        return e.checker.is_free()

    try:
        rng = functools.partial(request_rng, salt, pos, quat, start)
        with scene.holding(robot_id):
            res = solve_ik(b, pos, quat, start, rng, is_free if want_free else None, e.sphere)
        if not want_free:
            res = replace(res, collision_free=is_free(np.array(res.positions)))
        return res
    finally:
        b.apply(saved)


@dataclass(frozen=True)
class Tracker:
    """Differential IK along a path of poses: each pose solved by damped least squares from the joints of
    the previous one only (never a restart), so the joints stay on the branch they started on. Built per
    path (``tracker``): the vectorised FK of the end link at the robot's base, followers coupled."""

    fk: ChainFK
    bound: BoundRobot
    #: residuals a tracked pose must meet (m, rad)
    position_tolerance: float
    orientation_tolerance: float

    def step(self, seed: npt.NDArray[np.float64], position: Sequence[float],
             quat_xyzw: Sequence[float] | None) -> tuple[npt.NDArray[np.float64] | None, str | None]:
        """The joints at the pose nearest ``seed`` on its branch, or None with the cause in words when it
        ends there: a joint (or follower) at its limit, or a singularity; None and no cause when neither
        explains it (the pose is beyond the reach, or only another configuration reaches it)."""
        from scipy.spatial.transform import Rotation

        b = self.bound
        rotation = None if quat_xyzw is None else Rotation.from_quat([float(x) for x in quat_xyzw])
        tol_p, tol_o = self.position_tolerance, self.orientation_tolerance
        res = track_chain_ik(self.fk, np.asarray(position, dtype=np.float64), rotation, seed, b.lower,
                             b.upper, (tol_p, tol_o))
        q = b.pin(res.q[0])
        linked = not len(b.followers) or bool(b.followers.within(q)[0])
        if res.position_error[0] <= tol_p and res.orientation_error[0] <= tol_o and linked:
            return q, None
        return None, self.cause(seed, q)

    def cause(self, seed: npt.NDArray[np.float64], q: npt.NDArray[np.float64]) -> str | None:
        """Why the branch from ``seed`` ends where damped least squares stopped at ``q``, if a limit or a
        singularity says it."""
        b = self.bound
        names = b.ctrl_names
        for j in range(len(q)):
            for side, limit in (("lower", b.lower[j]), ("upper", b.upper[j])):
                if math.isfinite(limit) and abs(q[j] - limit) <= AT_LIMIT and abs(seed[j] - limit) < 0.35:
                    return f"joint {names[j]} reaches its {side} limit ({limit:.3f})"
        if len(b.followers):
            past = b.followers.first_violation(q)
            if past is not None:
                return f"joint {past[0]} (following others) would pass its limit"
        sigma = smallest_singular_value(self.fk, seed, orientation=len(q) >= 6)
        if sigma < SINGULAR:
            return f"a singularity (the Jacobian's smallest singular value is {sigma:.3g})"
        return None

    def singular_words(self, q: npt.NDArray[np.float64]) -> str:
        """``q`` named as singular or not, for a refusal where joints race."""
        sigma = smallest_singular_value(self.fk, q, orientation=len(q) >= 6)
        if sigma < SINGULAR:
            return f"a singularity (the Jacobian's smallest singular value is {sigma:.3g})"
        return "a configuration flip"


def tracker(scene: Scene, robot_id: str, position_tolerance: float, orientation_tolerance: float) -> Tracker:
    """A `Tracker` of a robot of ``scene`` at its base as it is now."""
    b = scene.entry(robot_id).bound
    return Tracker(b.linkage_fk(), b, position_tolerance, orientation_tolerance)
