"""World core: the PyBullet client, the robots and the thread that owns them (see ``world.py`` for the
full API)."""

from __future__ import annotations

import contextlib
import functools
import math
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, ParamSpec, Self, TypeVar

import numpy as np
import numpy.typing as npt

from robwot_sim import validate as v
from robwot_sim.errors import InvalidParams, NameTaken, UnknownRobot
from robwot_sim.model.decompose import OnMesh
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.collision import BodyTable
from robwot_sim.sim.collision_queries import CollisionQueries
from robwot_sim.sim.detour import DetourMemory
from robwot_sim.sim.loader import RobotEntry, RobotFiles, load_robot_body, read_robot_files
from robwot_sim.sim.pathcheck import MAX_CLEARANCE, MIN_CLEARANCE
from robwot_sim.sim.sweep import CLEARANCE
from robwot_sim.sim.types import RobotModel
from robwot_sim.sim.world_thread import holding

Vec3 = Sequence[float]
Quat = Sequence[float]
JointVector = Sequence[float] | npt.NDArray[np.float64]
P = ParamSpec("P")
R = TypeVar("R")


def _owned(fn: Callable[P, R]) -> Callable[P, R]:
    """A public World method: refused from any thread but the owner's, once one is bound (``bind``)."""
    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        owner = args[0]._owner  # type: ignore[attr-defined]
        if owner is not None and owner != threading.get_ident():
            raise RuntimeError(f"World.{fn.__name__} called off the world's thread")
        return fn(*args, **kwargs)

    return wrapper


class WorldBase:
    """Robots in one PyBullet DIRECT client (obstacles: ``WorldScene``). Context manager; ``close()``."""

    def __init__(self, ik_seed: int = 0) -> None:
        self._owner: int | None = None  # the only thread that may use the world, once bound
        self.bullet = Bullet()
        self.table = BodyTable()
        self._robots: dict[str, RobotEntry] = {}
        self._obstacles: dict[str, tuple[int, dict[str, Any]]] = {}
        self._built: dict[str, dict[str, Any]] = {}  # per obstacle: the shape its body was built from
        self._ik_salt = ik_seed  # salts the per-request IK restart seeds (see World.ik)
        #: the batch collision queries and their caches, kept until the scene changes
        self.queries = CollisionQueries(self)
        self._moves: dict[str, int] = {}  # per robot: how often its joints were set (see others_stamp)
        self._detours: dict[str, DetourMemory] = {}  # per robot: its last detours (World.detour)

    def bind(self) -> None:
        """From now on only the calling thread may use the world (the server's `WorldThread`): a call
        from another thread raises instead of racing it. PyBullet is not thread-safe."""
        self._owner = threading.get_ident()

    @contextlib.contextmanager
    def _holding(self, robot_id: str) -> Iterator[None]:
        """A long operation moves ``robot_id`` through many states and restores it at its end; at its
        checkpoints (`world_thread.checkpoint`) the robot is put back at its true state meanwhile."""
        b = self._entry(robot_id).bound
        true_q = b.q.copy()

        def park() -> Callable[[], None]:
            search_q = b.q.copy()
            b.apply(true_q)
            return lambda: b.apply(search_q)

        with holding(robot_id, park):
            yield

    @contextlib.contextmanager
    def hypothetical(self, robot_id: str) -> Iterator[None]:
        """Within this block ``place`` puts the robot in states it is not in (a program planned step after
        step); checkpoints show others its true state, and the block ends with the robot back there."""
        b = self._entry(robot_id).bound
        saved = b.q.copy()
        with self._holding(robot_id):
            try:
                yield
            finally:
                b.apply(saved)

    def place(self, robot_id: str, q: JointVector) -> None:
        """Puts the robot at ``q`` for planning from there (inside ``hypothetical``; limits checked)."""
        b = self._entry(robot_id).bound
        b.apply(b.validate(q))

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.queries.close()
        self.bullet.close()

    def _entry(self, robot_id: str) -> RobotEntry:
        if robot_id not in self._robots:
            raise UnknownRobot(str(robot_id), self._robots)
        return self._robots[robot_id]

    def _changed(self) -> None:
        self.table.version += 1

    # what the collision queries read (`collision_queries.SceneView`)
    @property
    def version(self) -> int:
        """Bumped on every change of the bodies (added, moved, removed)."""
        return self.table.version

    def entries(self) -> Mapping[str, RobotEntry]:
        return self._robots

    def obstacle_bodies(self) -> list[tuple[int, dict[str, Any]]]:
        return list(self._obstacles.values())

    def built_specs(self) -> list[dict[str, Any]]:
        """The obstacles' specs with the shapes the world built them from (a mesh: the file PyBullet may
        load, an ASCII STL converted, and its hull), for the mirror worlds: PyBullet crashes on some files
        the specs name."""
        return [{**spec, "shape": self._built.get(name, spec["shape"])}
                for name, (_, spec) in self._obstacles.items()]

    @_owned
    def others_stamp(self, robot_id: str) -> tuple[int, int]:
        """Changes to everything but ``robot_id``'s own joints: obstacles and robots added, moved or removed,
        other robots' joints set. Equal stamps: the world the robot moves in is the same."""
        return self.table.version, sum(n for rid, n in self._moves.items() if rid != robot_id)

    def _check_free_name(self, name: str) -> None:
        if name in self._robots or name in self._obstacles:
            raise NameTaken(name)

    # robots
    @staticmethod
    def read_robot(
        urdf: str | Path,
        *,
        robot_id: str | None = None,
        ee_link: str | None = None,
        package_roots: Mapping[str, str] | None = None,
        srdf: str | Path | None = None,
        _base_dir: Path | None = None,
        decompose: bool = True,
        on_mesh: OnMesh | None = None,
    ) -> RobotFiles:
        """The part of a load that needs no world (any thread): params checked, URDF/SRDF read, meshes
        parsed, concave ones split into convex parts (minutes for a robot's first load). ``add_robot``
        then creates the body. ``on_mesh`` hears of each mesh decomposed."""
        if robot_id is not None:
            v.name("id", robot_id)
        if ee_link is not None:
            v.name("eeLink", ee_link)
        if not isinstance(urdf, (str, Path)) or not str(urdf):
            raise InvalidParams("urdf must be a file path", param="urdf", expected="string", got=urdf)
        roots = v.string_map("packageRoots", package_roots)
        if srdf is not None and (not isinstance(srdf, (str, Path)) or not str(srdf)):
            raise InvalidParams("srdf must be a file path", param="srdf", expected="string", got=srdf)
        return read_robot_files(urdf, ee_link, roots, _base_dir, srdf, decompose, on_mesh)

    @_owned
    def load_robot(
        self,
        urdf: str | Path,
        *,
        robot_id: str | None = None,
        base_position: Vec3 = (0.0, 0.0, 0.0),
        base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
        ee_link: str | None = None,
        package_roots: Mapping[str, str] | None = None,
        srdf: str | Path | None = None,
        clearance: float = CLEARANCE,
        _base_dir: Path | None = None,
        decompose: bool = True,
    ) -> RobotModel:
        """Load a fixed-base robot. Relative URDF paths: cwd, then pybullet_data. Returns its joint model.
        ``clearance`` (m) is what its checked paths and motions keep to other bodies. = ``read_robot``
        then ``add_robot``."""
        if robot_id is not None:
            self._check_free_name(v.name("id", robot_id))
        files = self.read_robot(urdf, robot_id=robot_id, ee_link=ee_link, package_roots=package_roots,
                                srdf=srdf, _base_dir=_base_dir, decompose=decompose)
        return self.add_robot(files, robot_id=robot_id, base_position=base_position,
                              base_orientation=base_orientation, clearance=clearance)

    @_owned
    def add_robot(
        self,
        files: RobotFiles,
        *,
        robot_id: str | None = None,
        base_position: Vec3 = (0.0, 0.0, 0.0),
        base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
        clearance: float = CLEARANCE,
        accelerations: Mapping[str, float] | None = None,
    ) -> RobotModel:
        """Create the body of ``files`` (``read_robot``) in the world; removes their temporary copy.
        ``accelerations``: joint -> acceleration limit (rad/s^2 or m/s^2) of controllable joints."""
        try:
            if robot_id is not None:
                self._check_free_name(v.name("id", robot_id))
            pos = v.position("basePosition", base_position)
            quat = v.quaternion("baseOrientation", base_orientation)
            if not (isinstance(clearance, float | int) and MIN_CLEARANCE <= clearance <= MAX_CLEARANCE):
                raise InvalidParams(f"clearance must be in [{MIN_CLEARANCE}, {MAX_CLEARANCE}] m",
                                    param="clearance",
                                    expected=f"number in [{MIN_CLEARANCE}, {MAX_CLEARANCE}]", got=clearance)
            movable = [j.name for j in files.urdf_model.joints if j.type != "fixed"]
            limits = _accelerations(movable, accelerations or {})
        except Exception:
            files.cleanup()
            raise
        entry = load_robot_body(self.bullet, self.table, files, robot_id or "robot", pos, quat)
        if robot_id is None:
            base, k, rid = entry.model.name or "robot", 2, entry.model.name or "robot"
            while rid in self._robots or rid in self._obstacles:
                rid, k = f"{base}-{k}", k + 1
            entry.model = replace(entry.model, id=rid)
        entry.clearance = float(clearance)
        entry.model = replace(entry.model, clearance=entry.clearance, accelerations=limits)
        rid = entry.model.id
        self._robots[rid] = entry
        self.table.names[entry.bound.body] = rid
        self.table.robots[entry.bound.body] = entry.bound
        self._changed()
        return entry.model

    @_owned
    def remove_robot(self, robot_id: str) -> None:
        e = self._entry(robot_id)
        self.bullet.remove_body(e.bound.body)
        del self._robots[robot_id]
        del self.table.names[e.bound.body]
        del self.table.robots[e.bound.body]
        self._detours.pop(robot_id, None)
        self._changed()

    @_owned
    def robot_model(self, robot_id: str) -> RobotModel:
        return self._entry(robot_id).model

    @_owned
    def robot_ids(self) -> list[str]:
        return list(self._robots)

    @_owned
    def get_joint_positions(self, robot_id: str) -> npt.NDArray[np.float64]:
        return self._entry(robot_id).bound.q.copy()

    @_owned
    def set_joint_positions(self, robot_id: str, q: JointVector) -> None:
        """Teleport the controllable joints (limits checked; mimic joints follow)."""
        b = self._entry(robot_id).bound
        b.apply(b.validate(q))
        self._moves[robot_id] = self._moves.get(robot_id, 0) + 1


def _accelerations(movable: Sequence[str], given: Mapping[str, float]) -> dict[str, float]:
    """``given`` checked: each a movable joint's, a positive finite number."""
    out: dict[str, float] = {}
    for joint, value in given.items():
        if joint not in movable:
            raise InvalidParams(f"accelerationLimits: {joint!r} is not a movable joint of the robot",
                                param="accelerationLimits", expected=list(movable), got=joint)
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < math.inf:
            raise InvalidParams(f"accelerationLimits: {joint!r} must be a positive number, got {value!r}",
                                param="accelerationLimits", expected="positive number", got=value)
        out[joint] = float(value)
    return out

