"""World core: the PyBullet client, the robots and the lock (see ``world.py`` for the full API)."""

from __future__ import annotations

import contextlib
import functools
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, ParamSpec, Self, TypeVar

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams, NameTaken, UnknownRobot
from robwot_sim.sim import validate as v
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.collision import BodyTable
from robwot_sim.sim.fastworld import FastWorld
from robwot_sim.sim.loader import RobotEntry, load_robot_body
from robwot_sim.sim.pathcheck import MAX_CLEARANCE, MIN_CLEARANCE
from robwot_sim.sim.surehit import SureHits
from robwot_sim.sim.sweep import CLEARANCE
from robwot_sim.sim.types import RobotModel

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


class WorldBase:
    """Robots in one PyBullet DIRECT client (obstacles: ``WorldScene``). Context manager; ``close()``."""

    def __init__(self, ik_seed: int = 0) -> None:
        self._lock = threading.RLock()
        self.bullet = Bullet()
        self.table = BodyTable()
        self._robots: dict[str, RobotEntry] = {}
        self._obstacles: dict[str, tuple[int, dict[str, Any]]] = {}
        self._ik_salt = ik_seed  # salts the per-request IK restart seeds (see World.ik)
        self._fast: FastWorld | None = None  # collision-only mirror for batches, rebuilt on change
        self._sure: dict[str, tuple[int, SureHits]] = {}  # sure-hit tests by robot, with table.version
        self._moves: dict[str, int] = {}  # per robot: how often its joints were set (see others_stamp)

    @contextlib.contextmanager
    def exclusive(self) -> Iterator[None]:
        """Hold the world for a sequence of calls made from a worker thread (a plan): no other thread
        touches it meanwhile, and the asyncio loop stays free for what does not need it (heartbeats,
        stop requests)."""
        with self._lock:
            yield

    def __enter__(self) -> Self:
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

    @_locked
    def others_stamp(self, robot_id: str) -> tuple[int, int]:
        """Changes to everything but ``robot_id``'s own joints: obstacles and robots added, moved or removed,
        other robots' joints set. Equal stamps: the world the robot moves in is the same."""
        return self.table.version, sum(n for rid, n in self._moves.items() if rid != robot_id)

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
        srdf: str | Path | None = None,
        clearance: float = CLEARANCE,
        _base_dir: Path | None = None,
        decompose: bool = True,
    ) -> RobotModel:
        """Load a fixed-base robot. Relative URDF paths: cwd, then pybullet_data. Returns its joint model.
        ``clearance`` (m) is what its checked paths and motions keep to other bodies."""
        if robot_id is not None:
            self._check_free_name(v.name("id", robot_id))
        if ee_link is not None:
            v.name("eeLink", ee_link)
        if not isinstance(urdf, (str, Path)) or not str(urdf):
            raise InvalidParams("urdf must be a file path", param="urdf", expected="string", got=urdf)
        pos = v.position("basePosition", base_position)
        quat = v.quaternion("baseOrientation", base_orientation)
        roots = v.string_map("packageRoots", package_roots)
        if not (isinstance(clearance, float | int) and MIN_CLEARANCE <= clearance <= MAX_CLEARANCE):
            raise InvalidParams(f"clearance must be in [{MIN_CLEARANCE}, {MAX_CLEARANCE}] m",
                                param="clearance", expected=f"number in [{MIN_CLEARANCE}, {MAX_CLEARANCE}]",
                                got=clearance)
        tmp_id = robot_id or "robot"
        if srdf is not None and (not isinstance(srdf, (str, Path)) or not str(srdf)):
            raise InvalidParams("srdf must be a file path", param="srdf", expected="string", got=srdf)
        entry = load_robot_body(
            self.bullet, self.table, urdf, tmp_id, pos, quat, ee_link, roots, _base_dir, srdf, decompose
        )
        if robot_id is None:
            base, k, rid = entry.model.name or "robot", 2, entry.model.name or "robot"
            while rid in self._robots or rid in self._obstacles:
                rid, k = f"{base}-{k}", k + 1
            entry.model = replace(entry.model, id=rid)
        entry.clearance = float(clearance)
        entry.model = replace(entry.model, clearance=entry.clearance)
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

    @_locked
    def get_joint_positions(self, robot_id: str) -> npt.NDArray[np.float64]:
        return self._entry(robot_id).bound.q.copy()

    @_locked
    def set_joint_positions(self, robot_id: str, q: JointVector) -> None:
        """Teleport the controllable joints (limits checked; mimic joints follow)."""
        b = self._entry(robot_id).bound
        b.apply(b.validate(q))
        self._moves[robot_id] = self._moves.get(robot_id, 0) + 1
