"""IK of a robot of a scene, as a request asks it: the solver (``kinematics.solve_ik``) run with the robot
held (``Scene.holding``), collision-free by the scene's checker, its random restarts seeded from the request
itself, the robot's state unchanged."""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from robwot_sim import validate as v
from robwot_sim.sim.kinematics import solve_ik
from robwot_sim.sim.planning_scene import Quat, Scene, Vec3
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import IkResult


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
        rng = request_rng(salt, pos, quat, start)
        with scene.holding(robot_id):
            res = solve_ik(b, pos, quat, start, rng, is_free if want_free else None, e.sphere)
        if not want_free:
            res = replace(res, collision_free=is_free(np.array(res.positions)))
        return res
    finally:
        b.apply(saved)
