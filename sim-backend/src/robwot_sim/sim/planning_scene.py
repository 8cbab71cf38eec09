"""The planning scene (MoveIt's): the bodies of one PyBullet DIRECT client, robots, static obstacles and
objects (obstacles whose pose changes: each settled where it comes to rest, ``settle.py``), their states
and their versions. Everything that is a body lives here: what plans, checks or labels
reads a scene and never keeps bodies of its own.

Every public method checks its input before touching the client: a failed call changes nothing.
PyBullet is not thread-safe: once ``bind`` is called only that thread may use the scene (the server's
`world_thread.WorldThread`); calls from others are refused. A long search moves a robot through states
it is not in: it holds the robot (``holding``), so that at its checkpoints others see the true state.
"""

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

from robwot_sim import validate as v
from robwot_sim.errors import InvalidParams, NameTaken, UnknownObject, UnknownRobot
from robwot_sim.limits import DEFAULT_CLEARANCE, MAX_OBJECTS
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.collision import BodyTable
from robwot_sim.sim.kinematics import fk_pose
from robwot_sim.sim.loader import RobotEntry, RobotFiles, load_limits, load_robot_body
from robwot_sim.sim.outerbounds import BoundsCache
from robwot_sim.sim.scene_files import (
    ReadObstacle,
    SceneFiles,
    read_object,
    read_obstacle,
    read_robot,
    read_scene,
)
from robwot_sim.sim.settle import Placed, check_placed, in_column, settle
from robwot_sim.sim.types import CollisionReport, Pose
from robwot_sim.sim.world_thread import holding

Vec3 = Sequence[float]
Quat = Sequence[float]
JointVector = Sequence[float] | npt.NDArray[np.float64]
P = ParamSpec("P")
R = TypeVar("R")


def owned(fn: Callable[P, R]) -> Callable[P, R]:
    """A public Scene method: refused from any thread but the owner's, once one is bound (``bind``)."""
    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        owner = args[0]._owner  # type: ignore[attr-defined]
        if owner is not None and owner != threading.get_ident():
            raise RuntimeError(f"Scene.{fn.__name__} called off the world's thread")
        return fn(*args, **kwargs)

    return wrapper


class Scene:
    """Robots, static obstacles and objects in one PyBullet DIRECT client. Context manager; ``close()``.
    An object is an obstacle (a static body every check sees, named in every contact) whose pose changes:
    ``_obstacles`` holds both, ``_objects`` names the objects."""

    def __init__(self) -> None:
        self._owner: int | None = None  # the only thread that may use the scene, once bound
        self.bullet = Bullet()
        self.table = BodyTable()
        self._robots: dict[str, RobotEntry] = {}
        self._obstacles: dict[str, tuple[int, dict[str, Any]]] = {}
        self._built: dict[str, dict[str, Any]] = {}  # per obstacle: the shape its body was built from
        self._objects: set[str] = set()  # the obstacles that are objects
        self._moves: dict[str, int] = {}  # per robot: how often its joints were set (see others_stamp)
        self.bounds = BoundsCache()  # the robots' outer bounds (``outerbounds.py``)

    def bind(self) -> None:
        """From now on only the calling thread may use the scene: a call from another thread raises
        instead of racing it. PyBullet is not thread-safe."""
        self._owner = threading.get_ident()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.bullet.close()

    # versions
    @property
    def version(self) -> int:
        """Bumped on every change of the bodies (added, moved, removed)."""
        return self.table.version

    def _changed(self) -> None:
        self.table.version += 1

    @owned
    def others_stamp(self, robot_id: str) -> tuple[int, int]:
        """Changes to everything but ``robot_id``'s own joints: obstacles and robots added, moved or removed,
        other robots' joints set. Equal stamps: the world the robot moves in is the same."""
        return self.table.version, sum(n for rid, n in self._moves.items() if rid != robot_id)

    # robots
    @owned
    def entry(self, robot_id: str) -> RobotEntry:
        """The robot in the scene: its model, body, collision checker and path guard."""
        if robot_id not in self._robots:
            raise UnknownRobot(str(robot_id), self._robots)
        return self._robots[robot_id]

    @owned
    def entries(self) -> Mapping[str, RobotEntry]:
        return self._robots

    @owned
    def robot_model(self, robot_id: str) -> RobotModel:
        return self.entry(robot_id).model

    @owned
    def robot_ids(self) -> list[str]:
        return list(self._robots)

    def _check_free_name(self, name: str) -> None:
        if name in self._robots or name in self._obstacles:
            raise NameTaken(name)

    @owned
    def load_robot(self, urdf: str | Path, *, robot_id: str | None = None,
                   base_position: Vec3 = (0.0, 0.0, 0.0), base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
                   ee_link: str | None = None, package_roots: Mapping[str, str] | None = None,
                   srdf: str | Path | None = None, clearance: float = DEFAULT_CLEARANCE,
                   _base_dir: Path | None = None, decompose: bool = True) -> RobotModel:
        """Load a fixed-base robot. Relative URDF paths: cwd, then pybullet_data. Returns its joint model.
        ``clearance`` (m) is what its checked paths and motions keep to other bodies. =
        ``scene_files.read_robot`` then ``add_robot``."""
        if robot_id is not None:
            self._check_free_name(v.name("id", robot_id))
        files = read_robot(urdf, robot_id=robot_id, ee_link=ee_link, package_roots=package_roots, srdf=srdf,
                           _base_dir=_base_dir, decompose=decompose)
        return self.add_robot(files, robot_id=robot_id, base_position=base_position,
                              base_orientation=base_orientation, clearance=clearance)

    @owned
    def add_robot(
        self,
        files: RobotFiles,
        *,
        robot_id: str | None = None,
        base_position: Vec3 = (0.0, 0.0, 0.0),
        base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
        clearance: float = DEFAULT_CLEARANCE,
        accelerations: Mapping[str, float] | None = None,
        jerks: Mapping[str, float] | None = None,
    ) -> RobotModel:
        """Create the body of ``files`` (``scene_files.read_robot``); removes their temporary copy.
        ``accelerations`` / ``jerks``: joint -> limit (rad/s^2, rad/s^3 or m/...) of controllable joints."""
        try:
            if robot_id is not None:
                self._check_free_name(v.name("id", robot_id))
            pos = v.position("basePosition", base_position)
            quat = v.quaternion("baseOrientation", base_orientation)
            movable = [j.name for j in files.urdf_model.joints if j.type != "fixed"]
            limits = load_limits(movable, clearance, accelerations or {}, jerks or {})
        except Exception:
            files.cleanup()
            raise
        entry = self.build_entry(files, robot_id or "robot", pos, quat, clearance, *limits)
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

    @owned
    def remove_robot(self, robot_id: str) -> None:
        e = self.entry(robot_id)
        self.bullet.remove_body(e.bound.body)
        del self._robots[robot_id]
        del self.table.names[e.bound.body]
        del self.table.robots[e.bound.body]
        self._changed()

    @owned
    def build_entry(self, files: RobotFiles, robot_id: str, pos: Vec3, quat: Quat, clearance: float,
                    accelerations: Mapping[str, float], jerks: Mapping[str, float]) -> RobotEntry:
        """A body of ``files`` set up as a robot of the scene (``add_robot``; a robot rebuilt with a link
        added, ``gripper.py``), not yet in it: every check ignores it until ``swap_entry`` or removed."""
        entry = load_robot_body(self.bullet, self.table, files, robot_id, list(pos), list(quat))
        entry.clearance = float(clearance)
        entry.model = replace(entry.model, clearance=entry.clearance, accelerations=dict(accelerations),
                              jerks=dict(jerks))
        entry.checker.sure_free = functools.partial(self.bounds.sure_free, self, robot_id, entry)
        return entry

    @owned
    def swap_entry(self, robot_id: str, entry: RobotEntry) -> RobotEntry:
        """Robot ``robot_id`` is ``entry`` from now on (a body of it with a link added or removed,
        ``gripper.py``); returns the entry it was, whose body leaves every check (the caller parks or
        removes it)."""
        old = self.entry(robot_id)
        del self.table.names[old.bound.body]
        del self.table.robots[old.bound.body]
        self._robots[robot_id] = entry
        self.table.names[entry.bound.body] = robot_id
        self.table.robots[entry.bound.body] = entry.bound
        self._changed()
        return old

    # states
    @owned
    def get_joint_positions(self, robot_id: str) -> npt.NDArray[np.float64]:
        return self.entry(robot_id).bound.q.copy()

    @owned
    def set_joint_positions(self, robot_id: str, q: JointVector) -> None:
        """Teleport the controllable joints (limits checked; mimic joints follow)."""
        b = self.entry(robot_id).bound
        b.apply(b.validate(q))
        self._moves[robot_id] = self._moves.get(robot_id, 0) + 1

    @contextlib.contextmanager
    def holding(self, robot_id: str) -> Iterator[None]:
        """A long operation moves ``robot_id`` through many states and restores it at its end; at its
        checkpoints (`world_thread.checkpoint`) the robot is put back at its true state meanwhile."""
        b = self.entry(robot_id).bound
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
        saved = self.entry(robot_id).bound.q.copy()
        with self.holding(robot_id):
            try:
                yield
            finally:  # the robot's body now: a gripper may have rebuilt it meanwhile
                self.entry(robot_id).bound.apply(saved)

    @owned
    def place(self, robot_id: str, q: JointVector) -> None:
        """Puts the robot at ``q`` for planning from there (inside ``hypothetical``; limits checked)."""
        b = self.entry(robot_id).bound
        b.apply(b.validate(q))

    @owned
    def fk(self, robot_id: str, q: JointVector | None = None) -> Pose:
        """End-effector link frame (world) at ``q`` (default: current state, which is left unchanged)."""
        b = self.entry(robot_id).bound
        if q is None:
            return fk_pose(b)
        qv, saved = b.validate(q), b.q.copy()
        try:
            b.apply(qv)
            return fk_pose(b)
        finally:
            b.apply(saved)

    @owned
    def check_collision(self, robot_id: str, q: JointVector | None = None) -> CollisionReport:
        """What the robot touches at ``q`` (default: current state), itself and other bodies. No state
        change."""
        e = self.entry(robot_id)
        saved = e.bound.q.copy()
        try:
            if q is not None:
                e.bound.apply(e.bound.validate(q))
            contacts = e.checker.contacts()
        finally:
            e.bound.apply(saved)
        return CollisionReport(not contacts, tuple(contacts))

    # obstacles
    def obstacle_bodies(self) -> list[tuple[int, dict[str, Any]]]:
        return list(self._obstacles.values())

    def built_specs(self) -> list[dict[str, Any]]:
        """The obstacles' specs with the shapes the scene built them from (a mesh: the file PyBullet may
        load, an ASCII STL converted, and its hull), for the mirror worlds: PyBullet crashes on some files
        the specs name."""
        return [{**spec, "shape": self._built.get(name, spec["shape"])}
                for name, (_, spec) in self._obstacles.items()]

    def _add_obstacle(self, obstacle: ReadObstacle) -> dict[str, Any]:
        spec, shape = obstacle
        self._check_free_name(spec["name"])
        try:
            body = self.bullet.create_static(shape, spec["position"], spec["orientation"])
        except Exception as e:  # a mesh PyBullet cannot read
            raise InvalidParams(
                f"obstacle {spec['name']!r}: {e}", param="shape", expected="loadable shape", got=spec["shape"]
            ) from None
        self._obstacles[spec["name"]] = (body, spec)
        self._built[spec["name"]] = shape
        self.table.names[body] = spec["name"]
        self._changed()
        return spec

    @owned
    def add_obstacle(self, spec: dict[str, Any] | ReadObstacle) -> dict[str, Any]:
        """Add a static obstacle ``{name, shape, position, orientation? | rpy?}`` (or one already read by
        ``scene_files.read_obstacle``, off the world's thread); returns it normalised."""
        return self._add_obstacle(spec if isinstance(spec, tuple) else read_obstacle(spec))

    def _known(self, name: str, *, objects: bool) -> tuple[int, dict[str, Any]]:
        """The body and spec of obstacle (object, with ``objects``) ``name``, else UnknownObject."""
        if name not in self._obstacles or (name in self._objects) != objects:
            raise UnknownObject(str(name), [n for n in self._obstacles if (n in self._objects) == objects])
        return self._obstacles[name]

    def _put(self, name: str, position: Vec3, orientation: Quat | None) -> dict[str, Any]:
        """Teleport obstacle or object ``name`` (orientation None: as it is), a version bump; returns its
        spec before."""
        pos = v.position("position", position)
        body, spec = self._obstacles[name]
        quat = list(spec["orientation"]) if orientation is None else v.quaternion("orientation", orientation)
        self.bullet.reset_base(body, pos, quat)
        self._obstacles[name] = (body, {**spec, "position": pos, "orientation": quat})
        self._changed()
        return spec

    @owned
    def move_obstacle(self, name: str, position: Vec3, orientation: Quat | None = None) -> dict[str, Any]:
        """Put an obstacle at ``position`` (m), turned to ``orientation`` (``[x, y, z, w]``; default: as
        it is)."""
        self._known(name, objects=False)
        self._put(name, position, orientation)
        return self._obstacles[name][1]

    @owned
    def remove_obstacle(self, name: str) -> None:
        self._known(name, objects=False)
        self._remove_body(name)

    def _remove_body(self, name: str) -> None:
        body, _ = self._obstacles.pop(name)
        self._built.pop(name, None)
        self._objects.discard(name)
        self.bullet.remove_body(body)
        del self.table.names[body]
        self._changed()

    # objects
    @owned
    def add_object(self, spec: dict[str, Any] | ReadObstacle) -> dict[str, Any]:
        """Add an object ``{name, shape, position, orientation? | rpy?, color?, mass?}`` (or one already
        read by ``scene_files.read_object``), settled onto what is below it; returns it at rest."""
        return self._add_objects([spec if isinstance(spec, tuple) else read_object(spec)])[0]

    def _add_objects(self, objects: Sequence[ReadObstacle], allow: int | None = None,
                     settle: bool = True) -> list[dict[str, Any]]:
        """Objects added and settled together (a scene's stack settles as one), all or nothing: each
        placed into another body or coming to rest touching a robot is refused (``settle.check_placed``)."""
        if len(self._objects) + len(objects) > MAX_OBJECTS:
            raise InvalidParams(
                f"a world holds at most {MAX_OBJECTS} objects: it holds {len(self._objects)}, "
                f"{len(objects)} more asked for", param="objects", expected=f"at most {MAX_OBJECTS} objects",
                got=len(self._objects) + len(objects))
        added: list[str] = []
        try:
            for obj in objects:
                added.append(self._add_obstacle(obj)["name"])
                self._objects.add(added[-1])
            for name in added:
                check_placed(self.bullet, self.table, self._obstacles[name][0], self._placed(name),
                             allow=allow)
            if settle:
                self._settle(added, allow)
        except Exception:
            for name in added:
                self._remove_body(name)
            raise
        return [self._obstacles[name][1] for name in added]

    def _settle(self, names: Sequence[str], allow: int | None = None) -> None:
        """Puts objects ``names`` where they come to rest (``settle.py``); one touching a robot there:
        ``Overlap``."""
        if not names:
            return
        moving = set(names)
        boxes = {name: self.bullet.aabb(body) for name, (body, _) in self._obstacles.items()}
        others = [(boxes[n], self._placed(n)) for n in self._obstacles if n not in moving]
        poses = settle([self._placed(n) for n in names], in_column([boxes[n] for n in names], others))
        for name, (pos, quat) in zip(names, poses, strict=True):
            body, spec = self._obstacles[name]
            self.bullet.reset_base(body, pos, quat)
            self._obstacles[name] = (body, {**spec, "position": list(pos), "orientation": list(quat)})
        self._changed()
        for name in names:
            check_placed(self.bullet, self.table, self._obstacles[name][0], self._placed(name), at_rest=True,
                         allow=allow)

    def _placed(self, name: str) -> Placed:
        _, spec = self._obstacles[name]
        return Placed(self._built[name], spec["position"], spec["orientation"], spec.get("mass", 0.0))

    @owned
    def move_object(self, name: str, position: Vec3, orientation: Quat | None = None) -> dict[str, Any]:
        """Teleport an object to ``position`` (m), turned to ``orientation`` (``[x, y, z, w]``; default: as
        it is), then settle it; refused (``Overlap``), it stays where it was. Returns it at rest."""
        body, _ = self._known(name, objects=True)
        before = self.carry_object(name, position, orientation)
        try:
            check_placed(self.bullet, self.table, body, self._placed(name))
            self._settle([name])
        except Exception:  # back where it rested, to the bit
            self.bullet.reset_base(body, before["position"], before["orientation"])
            self._obstacles[name] = (body, before)
            self._changed()
            raise
        return self._obstacles[name][1]

    @owned
    def carry_object(self, name: str, position: Vec3, orientation: Quat | None = None) -> dict[str, Any]:
        """Put an object at ``position`` (m), turned to ``orientation`` (default: as it is) as something
        carries it (a belt, ``cell.py``): not settled, not checked; a version bump, so every check sees it.
        Returns its spec before."""
        self._known(name, objects=True)
        return self._put(name, position, orientation)

    @owned
    def remove_object(self, name: str) -> None:
        self._known(name, objects=True)
        self._remove_body(name)

    # objects a gripper takes and lets go (``gripper.py``)
    @owned
    def object_bodies(self) -> dict[str, int]:
        """The objects' bodies by name."""
        return {name: self._obstacles[name][0] for name in sorted(self._objects)}

    @owned
    def object_read(self, name: str) -> ReadObstacle:
        """Object ``name``'s spec and the shape its body was built from."""
        _, spec = self._known(name, objects=True)
        return spec, self._built[name]

    @owned
    def return_object(self, read: ReadObstacle, robot_id: str | None, settle: bool = True) -> dict[str, Any]:
        """An object a robot let go of put back at its pose and settled (it may touch that robot), or
        (``settle`` False) put back exactly where it was before a trial (``gripper.py``)."""
        return self._add_objects([read], self.entry(robot_id).bound.body if robot_id else None, settle)[0]

    # scene documents
    @owned
    def load_scene(
        self, scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None
    ) -> dict[str, Any]:
        """Add a scene's obstacles and robots, all or nothing: ``{"robots": [id], "obstacles": [name]}``.
        = ``scene_files.read_scene`` then ``add_scene``."""
        return self.add_scene(read_scene(scene, package_roots))

    @owned
    def add_scene(self, files: SceneFiles) -> dict[str, Any]:
        """Add a read scene (``scene_files.read_scene``), all or nothing: its obstacles, its robots, then its
        objects, settled together; removes the robots' temporary copies."""
        added_obs: list[str] = []
        added_rob: list[str] = []
        try:
            for spec, _ in [*files.obstacles, *files.objects]:
                self._check_free_name(spec["name"])
            for obstacle in files.obstacles:
                added_obs.append(self._add_obstacle(obstacle)["name"])
            for r, robot_files in files.robots:
                quat = r.get("baseOrientation") or (
                    quat_from_rpy(r["baseRpy"]) if "baseRpy" in r else (0.0, 0.0, 0.0, 1.0)
                )
                model = self.add_robot(robot_files, robot_id=r.get("id"),
                                       base_position=r.get("basePosition", (0.0, 0.0, 0.0)),
                                       base_orientation=quat)
                added_rob.append(model.id)
                if "positions" in r:
                    self.set_joint_positions(model.id, r["positions"])
            objects = [spec["name"] for spec in self._add_objects(files.objects)]
        except Exception:  # all or nothing: undo what this scene added
            for rid in added_rob:
                self.remove_robot(rid)
            for name in added_obs:
                self._remove_body(name)
            raise
        finally:
            files.cleanup()
        return {"robots": added_rob, "obstacles": added_obs, "objects": objects}

    @owned
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
        specs = [(name, spec) for name, (_, spec) in self._obstacles.items()]
        return {"robots": robots, "obstacles": [spec for name, spec in specs if name not in self._objects],
                "objects": [spec for name, spec in specs if name in self._objects]}

    @owned
    def reset(self) -> None:
        """Remove every robot, obstacle and object."""
        for rid in list(self._robots):
            self.remove_robot(rid)
        for name in list(self._obstacles):
            self._remove_body(name)
