"""The simulation world: one PyBullet DIRECT client holding robots and static obstacles.

Every public method validates its input before touching the world: a failed call changes nothing.
PyBullet is not thread-safe: the server calls a World from one thread only (``world_thread.py``; once
``bind`` is called, other threads are refused). The long searches (``ik``, ``check_path``, ``detour``)
hold their robot (``_holding``) and reach checkpoints where queued short jobs run. The class is built in
layers: ``WorldBase`` (client, robots), ``WorldScene`` (obstacles, scenes), ``World`` (joints, kinematics,
collision, motion planning, export); the batch collision queries and their caches are a part of their own
(``queries``, ``collision_queries.py``).
"""

from __future__ import annotations

import functools
import hashlib
import itertools
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim import validate as v
from robwot_sim.errors import InvalidParams
from robwot_sim.limits import DEFAULT_DT, DEFAULT_SPEED, DEFAULT_TCP_SPEED, TCP_SPEED
from robwot_sim.sim.detour import BUDGET as DETOUR_BUDGET
from robwot_sim.sim.detour import DetourMemory, find_detour, recall
from robwot_sim.sim.export import export_urdf
from robwot_sim.sim.kinematics import fk_pose, solve_ik
from robwot_sim.sim.motion import (
    TCP_ACCELERATION,
    check_fraction,
    check_speed_dt,
    plan_curve_path,
    plan_joint_path,
)
from robwot_sim.sim.pathcheck import check_joint_path, first_contact, path_clearance
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.types import CollisionReport, IkResult, PathReport, Pose
from robwot_sim.sim.world_base import JointVector, Quat, Vec3, _owned
from robwot_sim.sim.world_scene import WorldScene

__all__ = ["World"]


def _request_rng(salt: int, *parts: Sequence[float] | npt.NDArray[np.float64] | None) -> np.random.Generator:
    """IK restarts seeded from the request itself (state, target, orientation): the same question always
    gets the same answer, so a target validated as reachable and collision-free is solved the same way
    when the move follows; different requests still get independent restarts."""
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        h.update(b"-" if p is None else np.ascontiguousarray(p, dtype=np.float64).tobytes())
    return np.random.default_rng([salt, *np.frombuffer(h.digest(), dtype=np.uint32).tolist()])


class World(WorldScene):
    """Robots + obstacles in one PyBullet DIRECT client. Context manager; call ``close()``."""

    @_owned
    def fk(self, robot_id: str, q: JointVector | None = None) -> Pose:
        """End-effector link frame (world) at ``q`` (default: current state, which is left unchanged)."""
        b = self._entry(robot_id).bound
        if q is None:
            return fk_pose(b)
        qv, saved = b.validate(q), b.q.copy()
        try:
            b.apply(qv)
            return fk_pose(b)
        finally:
            b.apply(saved)

    @_owned
    def ik(
        self,
        robot_id: str,
        position: Vec3,
        quat_xyzw: Quat | None = None,
        seed: Sequence[float] | None = None,
        collision_free: bool = True,
    ) -> IkResult:
        """Joint positions putting the end-effector frame at ``position`` (+ ``quat_xyzw``). Read-only."""
        e = self._entry(robot_id)
        b = e.bound
        pos = v.position("position", position)
        quat = None if quat_xyzw is None else v.quaternion("orientation", quat_xyzw)
        start = b.q.copy() if seed is None else b.validate(seed, "seed")
        want_free = v.flag("collisionFree", collision_free)
        saved = b.q.copy()

        def is_free(q: npt.NDArray[np.float64]) -> bool:
            b.apply(q)
            return e.checker.is_free()

        try:
            rng = _request_rng(self._ik_salt, pos, quat, start)
            with self._holding(robot_id):
                res = solve_ik(b, pos, quat, start, rng, is_free if want_free else None, e.sphere)
            if not want_free:
                res = replace(res, collision_free=is_free(np.array(res.positions)))
            return res
        finally:
            b.apply(saved)

    # collision
    @_owned
    def check_collision(self, robot_id: str, q: JointVector | None = None) -> CollisionReport:
        """Self and environment contacts at ``q`` (default: current state). No state change."""
        e = self._entry(robot_id)
        saved = e.bound.q.copy()
        try:
            if q is not None:
                e.bound.apply(e.bound.validate(q))
            contacts = e.checker.contacts()
        finally:
            e.bound.apply(saved)
        return CollisionReport(not contacts, tuple(contacts))

    @_owned
    def motion_clearance(self, robot_id: str, *through: JointVector) -> float:
        """The clearance (m) a motion from the current state through (or to) the states ``through``
        keeps (see pathcheck.path_clearance)."""
        e = self._entry(robot_id)
        return path_clearance(e.bound, e.checker, e.bound.q.copy(), e.guard,
                              *(e.bound.validate(q, "through") for q in through))

    @_owned
    def check_step(
        self, robot_id: str, q_from: JointVector, q_to: JointVector, clearance: float
    ) -> CollisionReport:
        """Contacts on the way from ``q_from`` to ``q_to`` (subdivided so no point travels more than
        MAX_SWEEP unchecked; other bodies closer than ``clearance`` count). No state change."""
        e = self._entry(robot_id)
        saved = e.bound.q.copy()
        try:
            hit = first_contact(e.bound, e.checker, np.asarray(q_from, dtype=np.float64),
                                np.asarray(q_to, dtype=np.float64), e.guard, clearance)
            contacts = e.checker.contacts(clearance) if hit is not None else []
        finally:
            e.bound.apply(saved)
        return CollisionReport(hit is None, tuple(contacts))

    @_owned
    def collision_free_batch(self, robot_id: str, qs: npt.NDArray[np.float64],
                             bounds: bool = False) -> npt.NDArray[np.bool_]:
        """Collision-free flag per configuration (rows of ``qs`` [n, dof]); restores the state
        (``CollisionQueries.free_batch``; ``bounds``: with the outer bounds)."""
        self._entry(robot_id)
        return self.queries.free_batch(robot_id, qs, bounds)

    # motion (planning only)
    @_owned
    def plan_motion(
        self,
        robot_id: str,
        target: JointVector,
        start: JointVector | None = None,
        speed: float = DEFAULT_SPEED,
        dt: float = DEFAULT_DT,
        via: Sequence[JointVector] = (),
        *,
        acceleration: float = 1.0,
        arc: Sequence[float] = (),
        tcp_speed: float | None = DEFAULT_TCP_SPEED,
    ) -> TimedPath:
        """The timed path from ``start`` (default current) through the waypoints ``via`` to ``target``: states
        one per ``dt`` (computed when asked for), within the joint velocity limits x ``speed`` and
        acceleration limits x ``acceleration`` (``motion.py``). Without ``arc``: each segment straight in
        joint space, at rest at every waypoint. With ``arc`` (the end effector's distance along its curve
        at start, every waypoint and target, metres): one smooth motion through them, the end effector at
        most ``tcp_speed`` (None: the joint limits only, a blended group of PTP steps)."""
        e = self._entry(robot_id)
        tgt = e.bound.validate(target, "target")
        st = e.bound.q.copy() if start is None else e.bound.validate(start, "from")
        points = [st, *(e.bound.validate(w, f"via[{i}]") for i, w in enumerate(via)), tgt]
        sp, step = check_speed_dt(speed, dt)
        accel = check_fraction("acceleration", acceleration)
        velocity = e.model.velocity_limits() * sp
        accelerations = e.model.acceleration_limits() * accel
        if len(arc):
            if len(arc) != len(points):
                raise InvalidParams("arc needs one distance per point", param="arc", expected=len(points),
                                    got=len(arc))
            tcp = None if tcp_speed is None else check_fraction("tcpSpeed", tcp_speed, TCP_SPEED)
            return TimedPath([plan_curve_path(points, arc, velocity, accelerations, tcp,
                                              TCP_ACCELERATION * accel, step, e.model.limits())], step)
        return TimedPath([plan_joint_path(a, b, velocity, accelerations, step)
                          for a, b in itertools.pairwise(points)], step)

    @_owned
    def check_path(
        self,
        robot_id: str,
        target: JointVector,
        start: JointVector | None = None,
        speed: float = DEFAULT_SPEED,
        dt: float = DEFAULT_DT,
        via: Sequence[JointVector] = (),
    ) -> PathReport:
        """Check every state of ``plan_motion`` for collision (world unchanged)."""
        return self.check_states(robot_id, self.plan_motion(robot_id, target, start, speed, dt, via))

    @_owned
    def check_states(self, robot_id: str, path: TimedPath) -> PathReport:
        """Check the states of ``path`` (``plan_motion``'s) and the moves between them for collision (world
        unchanged)."""
        e = self._entry(robot_id)
        with self._holding(robot_id):
            return check_joint_path(e.bound, e.checker, path, e.guard)

    @_owned
    def detour(self, robot_id: str, target: JointVector,
               budget: float = DETOUR_BUDGET) -> list[tuple[float, ...]] | None:
        """Waypoints (ending at ``target``) of a collision-free path from the current state around what
        blocks the straight one, or None. World unchanged. A stretch of a detour found before in this
        world (either way along it: `detour.DetourMemory`) is taken again when it still passes the path
        check; else RRT-Connect searches one (each segment checked like a path), remembered when found."""
        e = self._entry(robot_id)
        tgt = e.bound.validate(target, "target")
        saved = e.bound.q.copy()
        memory = self._detours.setdefault(robot_id, DetourMemory())
        version = self.table.version
        try:
            clearance = path_clearance(e.bound, e.checker, saved, e.guard, tgt)
            with self._holding(robot_id):
                found = recall(e.bound, e.checker, memory, version, saved, tgt, e.guard, clearance)
                if found is None:
                    found = find_detour(e.bound, e.checker, saved, tgt, e.guard, clearance, budget)
                    if found is not None:
                        memory.remember(version, [saved, *found])
        finally:
            e.bound.apply(saved)
        return None if found is None else [tuple(float(x) for x in w) for w in found]

    @_owned
    def export_robot(self, robot_id: str, out_dir: str | Path) -> dict[str, Any]:
        """Write a self-contained copy of the robot's URDF (meshes under ``meshes/``) into ``out_dir``."""
        return self.export_job(robot_id, out_dir)()

    @_owned
    def export_job(self, robot_id: str, out_dir: str | Path) -> Callable[[], dict[str, Any]]:
        """``export_robot`` as a function that needs no world (it copies files: any thread)."""
        e = self._entry(robot_id)
        if not isinstance(out_dir, (str, Path)) or not str(out_dir):
            raise InvalidParams(
                "outDir must be a folder path", param="outDir", expected="string", got=out_dir
            )
        return functools.partial(export_urdf, e.urdf_path, out_dir, e.package_roots, e.collision_parts)
