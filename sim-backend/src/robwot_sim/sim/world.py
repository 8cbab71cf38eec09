"""The simulation world: one PyBullet DIRECT client holding robots and static obstacles.

Every public method validates its input before touching the world: a failed call changes nothing.
Methods are serialised by a lock (the RPC layer may call from several threads).
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, ParamSpec, TypeVar

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams, NameTaken, SimError, UnknownObject, UnknownRobot
from robwot_sim.scene import normalise_obstacle, read_scene
from robwot_sim.sim import validate as v
from robwot_sim.sim.client import Bullet, quat_from_rpy
from robwot_sim.sim.collision import BodyTable
from robwot_sim.sim.fastworld import FastWorld, MirrorRobot
from robwot_sim.sim.kinematics import fk_pose, solve_ik
from robwot_sim.sim.loader import RobotEntry, load_robot_body
from robwot_sim.sim.motion import check_speed_dt, plan_joint_path
from robwot_sim.sim.pathcheck import check_joint_path
from robwot_sim.sim.types import CollisionReport, IkResult, PathReport, Pose, RobotModel
from robwot_sim.urdf import export_urdf

Vec3 = Sequence[float]
Quat = Sequence[float]
JointVector = Sequence[float] | npt.NDArray[np.float64]
P = ParamSpec("P")
R = TypeVar("R")


def _locked(fn: Callable[P, R]) -> Callable[P, R]:
    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with args[0]._lock:  # type: ignore[attr-defined]
            return fn(*args, **kwargs)

    return wrapper


class World:
    """Robots + obstacles in one PyBullet DIRECT client. Context manager; call ``close()``."""

    def __init__(self, ik_seed: int = 0) -> None:
        self._lock = threading.RLock()
        self.bullet = Bullet()
        self.table = BodyTable()
        self._robots: dict[str, RobotEntry] = {}
        self._obstacles: dict[str, tuple[int, dict[str, Any]]] = {}
        self._rng = np.random.default_rng(ik_seed)
        self._fast: FastWorld | None = None  # collision-only mirror for batches, rebuilt on change

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._fast is not None:
            self._fast.close()
            self._fast = None
        self.bullet.close()

    def _entry(self, robot_id: str) -> RobotEntry:
        if robot_id not in self._robots:
            raise UnknownRobot(str(robot_id), self._robots)
        return self._robots[robot_id]

    def _changed(self) -> None:
        self.table.version += 1

    def _check_free_name(self, name: str) -> None:
        if name in self._robots or name in self._obstacles:
            raise NameTaken(name)

    # robots
    @_locked
    def load_robot(
        self,
        urdf: str | Path,
        *,
        robot_id: str | None = None,
        base_position: Vec3 = (0.0, 0.0, 0.0),
        base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
        ee_link: str | None = None,
        package_roots: Mapping[str, str] | None = None,
        _base_dir: Path | None = None,
    ) -> RobotModel:
        """Load a fixed-base robot. Relative URDF paths: cwd, then pybullet_data. Returns its joint model."""
        if robot_id is not None:
            self._check_free_name(v.name("id", robot_id))
        if ee_link is not None:
            v.name("eeLink", ee_link)
        if not isinstance(urdf, (str, Path)) or not str(urdf):
            raise InvalidParams("urdf must be a file path", param="urdf", expected="string", got=urdf)
        pos = v.vector("basePosition", base_position, 3)
        quat = v.quaternion("baseOrientation", base_orientation)
        roots = v.string_map("packageRoots", package_roots)
        tmp_id = robot_id or "robot"
        entry = load_robot_body(self.bullet, self.table, urdf, tmp_id, pos, quat, ee_link, roots, _base_dir)
        if robot_id is None:
            base, k, rid = entry.model.name or "robot", 2, entry.model.name or "robot"
            while rid in self._robots or rid in self._obstacles:
                rid, k = f"{base}-{k}", k + 1
            entry.model = replace(entry.model, id=rid)
        rid = entry.model.id
        self._robots[rid] = entry
        self.table.names[entry.bound.body] = rid
        self.table.robots[entry.bound.body] = entry.bound
        self._changed()
        return entry.model

    @_locked
    def remove_robot(self, robot_id: str) -> None:
        e = self._entry(robot_id)
        self.bullet.remove_body(e.bound.body)
        del self._robots[robot_id]
        del self.table.names[e.bound.body]
        del self.table.robots[e.bound.body]
        self._changed()

    @_locked
    def robot_model(self, robot_id: str) -> RobotModel:
        return self._entry(robot_id).model

    @_locked
    def robot_ids(self) -> list[str]:
        return list(self._robots)

    # scene / obstacles
    @_locked
    def load_scene(
        self, scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None
    ) -> dict[str, Any]:
        """Add a scene's obstacles and robots, all or nothing: ``{"robots": [id], "obstacles": [name]}``."""
        if not isinstance(scene, (dict, str, Path)):
            raise InvalidParams(
                "scene must be an object or a file path", param="scene", expected="object", got=scene
            )
        roots = v.string_map("packageRoots", package_roots)
        doc, base, _file = read_scene(scene)
        specs = [normalise_obstacle(o, base) for o in doc.get("obstacles", [])]
        for s in specs:
            self._check_free_name(s["name"])
        added_obs: list[str] = []
        added_rob: list[str] = []
        try:
            for s in specs:
                added_obs.append(self._add_obstacle(s)["name"])
            for r in doc.get("robots", []):
                quat = r.get("baseOrientation") or (
                    quat_from_rpy(r["baseRpy"]) if "baseRpy" in r else (0.0, 0.0, 0.0, 1.0)
                )
                model = self.load_robot(
                    r["urdf"],
                    robot_id=r.get("id"),
                    base_position=r.get("basePosition", (0.0, 0.0, 0.0)),
                    base_orientation=quat,
                    ee_link=r.get("eeLink"),
                    package_roots={**roots, **r.get("packageRoots", {})},
                    _base_dir=base,
                )
                added_rob.append(model.id)
                if "positions" in r:
                    self.set_joint_positions(model.id, r["positions"])
        except SimError:
            for rid in added_rob:
                self.remove_robot(rid)
            for name in added_obs:
                self.remove_obstacle(name)
            raise
        return {"robots": added_rob, "obstacles": added_obs}

    def _add_obstacle(self, spec: dict[str, Any]) -> dict[str, Any]:
        self._check_free_name(spec["name"])
        try:
            body = self.bullet.create_static(spec["shape"], spec["position"], spec["orientation"])
        except Exception as e:  # a mesh PyBullet cannot read
            raise InvalidParams(
                f"obstacle {spec['name']!r}: {e}", param="shape", expected="loadable shape", got=spec["shape"]
            ) from None
        self._obstacles[spec["name"]] = (body, spec)
        self.table.names[body] = spec["name"]
        self._changed()
        return spec

    @_locked
    def add_obstacle(self, spec: dict[str, Any]) -> dict[str, Any]:
        """Add a static obstacle ``{name, shape, position, orientation? | rpy?}``; returns it normalised."""
        return self._add_obstacle(normalise_obstacle(spec))

    @_locked
    def move_obstacle(
        self, name: str, position: Vec3, orientation: Quat | None = None, rpy: Vec3 | None = None
    ) -> dict[str, Any]:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        pos = v.vector("position", position, 3)
        if orientation is not None and rpy is not None:
            raise InvalidParams(
                "give orientation or rpy, not both", param="rpy", expected="one of them", got=rpy
            )
        body, spec = self._obstacles[name]
        if orientation is not None:
            quat = v.quaternion("orientation", orientation)
        elif rpy is not None:
            quat = list(quat_from_rpy(v.vector("rpy", rpy, 3)))
        else:
            quat = list(spec["orientation"])
        self.bullet.reset_base(body, pos, quat)
        spec = {**spec, "position": pos, "orientation": quat}
        self._obstacles[name] = (body, spec)
        self._changed()
        return spec

    @_locked
    def remove_obstacle(self, name: str) -> None:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        body, _ = self._obstacles.pop(name)
        self.bullet.remove_body(body)
        del self.table.names[body]
        self._changed()

    @_locked
    def list(self) -> dict[str, Any]:
        robots = [
            {
                "id": rid,
                "urdf": e.model.urdf,
                "basePosition": list(e.model.base_position),
                "baseOrientation": list(e.model.base_orientation),
                "eeLink": e.model.ee_link,
            }
            for rid, e in self._robots.items()
        ]
        return {"robots": robots, "obstacles": [spec for _, spec in self._obstacles.values()]}

    @_locked
    def reset(self) -> None:
        """Remove every robot and obstacle."""
        for rid in list(self._robots):
            self.remove_robot(rid)
        for name in list(self._obstacles):
            self.remove_obstacle(name)

    @_locked
    def scene_spec(self) -> dict[str, Any]:
        """The current world as a scene document (absolute paths); ``load_scene`` rebuilds it."""
        robots = []
        for rid, e in self._robots.items():
            r: dict[str, Any] = {
                "id": rid,
                "urdf": str(e.urdf_path),
                "basePosition": list(e.model.base_position),
                "baseOrientation": list(e.model.base_orientation),
                "eeLink": e.model.ee_link,
                "positions": [float(x) for x in e.bound.q],
            }
            if e.package_roots:
                r["packageRoots"] = {
                    k: str(Path(p).expanduser().resolve()) for k, p in e.package_roots.items()
                }
            robots.append(r)
        return {"version": 1, "obstacles": [spec for _, spec in self._obstacles.values()], "robots": robots}

    # joints / kinematics
    @_locked
    def get_joint_positions(self, robot_id: str) -> npt.NDArray[np.float64]:
        return self._entry(robot_id).bound.q.copy()

    @_locked
    def set_joint_positions(self, robot_id: str, q: JointVector) -> None:
        """Teleport the controllable joints (limits checked; mimic joints follow)."""
        b = self._entry(robot_id).bound
        b.apply(b.validate(q))

    @_locked
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

    @_locked
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
        pos = v.vector("position", position, 3)
        quat = None if quat_xyzw is None else v.quaternion("orientation", quat_xyzw)
        start = b.q.copy() if seed is None else b.validate(seed, "seed")
        want_free = v.flag("collisionFree", collision_free)
        saved = b.q.copy()

        def is_free(q: npt.NDArray[np.float64]) -> bool:
            b.apply(q)
            return e.checker.is_free()

        try:
            res = solve_ik(b, pos, quat, start, self._rng, is_free if want_free else None)
            if not want_free:
                res = replace(res, collision_free=is_free(np.array(res.positions)))
            return res
        finally:
            b.apply(saved)

    # collision
    @_locked
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

    @_locked
    def collision_free_batch(self, robot_id: str, qs: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        """Collision-free flag per configuration (rows of ``qs`` [n, dof]); restores the state."""
        e = self._entry(robot_id)
        arr = np.asarray(qs, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != e.bound.dof:
            raise InvalidParams(
                f"expected an array [n, {e.bound.dof}]",
                param="qs",
                expected=f"[n, {e.bound.dof}]",
                got=list(arr.shape),
            )
        bad = (
            ~np.isfinite(arr).all(axis=1)
            | (arr < e.bound.lower - 1e-9).any(axis=1)
            | (arr > e.bound.upper + 1e-9).any(axis=1)
        )
        if bad.any():
            e.bound.validate(arr[int(np.argmax(bad))], f"qs[{int(np.argmax(bad))}]")
        if e.checker.static_contacts():
            return np.zeros(len(arr), dtype=bool)
        if e.checker.massless_moving:
            return e.checker.batch(arr)
        fast = self._fast_world()
        others = {rid: o.bound.full_values(o.bound.q) for rid, o in self._robots.items() if rid != robot_id}
        return fast.batch(robot_id, arr, others, e.bound.mimic)

    def _fast_world(self) -> FastWorld:
        if self._fast is None or self._fast.version != self.table.version:
            if self._fast is not None:
                self._fast.close()
                self._fast = None
            mirror = {
                rid: MirrorRobot(
                    e.urdf_path,
                    e.package_roots,
                    e.model.base_position,
                    e.model.base_orientation,
                    e.bound.set_idx,
                    e.checker.filtered,
                )
                for rid, e in self._robots.items()
            }
            self._fast = FastWorld(mirror, [spec for _, spec in self._obstacles.values()], self.table.version)
        return self._fast

    # motion (planning only)
    @_locked
    def plan_motion(
        self,
        robot_id: str,
        target: JointVector,
        start: JointVector | None = None,
        speed: float = 1.0,
        dt: float = 1.0 / 240.0,
    ) -> npt.NDArray[np.float64]:
        """Joint states [steps + 1, dof] from ``start`` (default current) to ``target``, one per ``dt``."""
        e = self._entry(robot_id)
        tgt = e.bound.validate(target, "target")
        st = e.bound.q.copy() if start is None else e.bound.validate(start, "from")
        sp, step = check_speed_dt(speed, dt)
        return plan_joint_path(st, tgt, e.model.velocity_limits(), sp, step)

    @_locked
    def check_path(
        self,
        robot_id: str,
        target: JointVector,
        start: JointVector | None = None,
        speed: float = 1.0,
        dt: float = 1.0 / 240.0,
    ) -> PathReport:
        """Check every state of ``plan_motion`` for collision (world unchanged)."""
        path = self.plan_motion(robot_id, target, start, speed, dt)
        e = self._entry(robot_id)
        return check_joint_path(e.bound, e.checker, path, float(dt))

    @_locked
    def export_robot(self, robot_id: str, out_dir: str | Path) -> dict[str, Any]:
        """Write a self-contained copy of the robot's URDF (meshes under ``meshes/``) into ``out_dir``."""
        e = self._entry(robot_id)
        if not isinstance(out_dir, (str, Path)) or not str(out_dir):
            raise InvalidParams(
                "outDir must be a folder path", param="outDir", expected="string", got=out_dir
            )
        return export_urdf(e.urdf_path, out_dir, e.package_roots)
