"""The simulation world: the parts one PyBullet client's work is split into, composed, each doing one job
(MoveIt's split):

- ``scene``: the bodies, robots and static obstacles, their states and versions
  (``planning_scene.Scene``);
- ``queries``: batch collision queries and their caches, kept by the scene's version
  (``collision_queries.CollisionQueries``);
- ``cell``: the conveyors carrying objects, the sensors watching them, the cell's time (``cell.Cell``);
- IK (``ik.py``), path checks (``pathcheck.py``), detours (``detour.py``, with the detours the World
  remembers) and trajectory timing (``trajectory.py``): free functions over the scene; planning itself
  (``planner.py``, ``program.py``) calls them through the World.

``World`` owns these parts and passes each call on to the part that does it: it holds no logic of its
own. PyBullet is not thread-safe: the server calls a World from one thread only (``world_thread.py``;
once ``bind`` is called, other threads are refused).
"""

from __future__ import annotations

import builtins
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Self

import numpy as np
import numpy.typing as npt

from robwot_sim.limits import DEFAULT_ACCELERATION, DEFAULT_DT, DEFAULT_SPEED, DEFAULT_TCP_SPEED
from robwot_sim.sim import detour as detours
from robwot_sim.sim import export, pathcheck, scene_doc, scene_files, trajectory
from robwot_sim.sim import ik as inverse_kinematics
from robwot_sim.sim.cell import Cell
from robwot_sim.sim.collision_queries import CollisionQueries
from robwot_sim.sim.gripper import Grippers
from robwot_sim.sim.outerbounds import OuterBounds
from robwot_sim.sim.planning_scene import JointVector, Quat, Scene, Vec3
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.types import CollisionReport, IkResult, PathReport

__all__ = ["World"]


class World:
    """A scene, its collision queries and what planning in it remembers. Context manager; ``close()``."""

    #: what needs no world: a robot's files, a scene document read and prepared (any thread)
    read_robot = staticmethod(scene_files.read_robot)
    read_scene = staticmethod(scene_files.read_scene)

    def __init__(self, ik_seed: int = 0) -> None:
        self.scene = scene = Scene()
        #: the batch collision queries and their caches, kept until the scene changes
        self.queries = CollisionQueries(scene)
        self._detours = detours.DetourMemory()  # each robot's last detours (``detour``)
        self._ik_salt = ik_seed  # salts the per-request IK restart seeds (``ik``)
        #: the robots' grippers and the objects they hold (``gripper.py``)
        self.grippers = Grippers(scene)
        #: the conveyors and sensors around the robots and the cell's time (``cell.py``)
        self.cell = cell = Cell(scene)
        cell.held = self.grippers.held_bodies  # sensors see what robots hold
        # bodies and their states: the scene's own methods
        self.bind = scene.bind
        self.load_robot = scene.load_robot
        self.add_robot = scene.add_robot
        self.robot_model = scene.robot_model
        self.robot_ids = scene.robot_ids
        self.get_joint_positions = scene.get_joint_positions
        self.set_joint_positions = scene.set_joint_positions
        self.others_stamp = scene.others_stamp
        self.hypothetical = scene.hypothetical
        self.place = scene.place
        self.fk = scene.fk
        self.check_collision = scene.check_collision
        self.add_obstacle = scene.add_obstacle
        self.move_obstacle = scene.move_obstacle
        self.remove_obstacle = cell.remove_obstacle  # a conveyor's belt: the conveyor too
        self.add_object = scene.add_object
        self.move_object = scene.move_object
        self.remove_object = scene.remove_object
        self.load_scene = cell.load_scene  # the scene's, with its conveyors and sensors
        self.add_scene = cell.add_scene

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.grippers.close_all()
        self.queries.close()
        self.scene.close()

    def remove_robot(self, robot_id: str) -> None:
        self.scene.remove_robot(robot_id)
        self.grippers.forget(robot_id)

    def reset(self) -> None:
        self.grippers.close_all()
        self.scene.reset()
        self.cell.clear()

    def warm_bounds(self) -> list[OuterBounds]:
        """Each robot's outer bounds built now (its shapes, the scene's grids) when the compiled kernels are
        loaded, so the first path check after them does not pay for it (empty bounds otherwise); the caller
        may fill their self pair tables off the world's thread (``OuterBounds.fill_tables``)."""
        return [self.scene.bounds.get(self.scene, rid) for rid in self.robot_ids()]

    def list(self) -> dict[str, Any]:
        """Robots, obstacles, objects, conveyors and sensors; a held object where the robot holding it has it
        (``heldBy``)."""
        out = self.scene.list()
        out["objects"] = [*out["objects"], *self.grippers.held_objects()]
        return self.cell.listed(out)

    def scene_spec(self) -> dict[str, Any]:
        """The world as a scene document (``scene_doc.scene_spec``) with the cell's conveyors and sensors."""
        return self.cell.documented(scene_doc.scene_spec(self.scene))

    def ik(self, robot_id: str, position: Vec3, quat_xyzw: Quat | None = None,
           seed: Sequence[float] | None = None, collision_free: bool = True) -> IkResult:
        return inverse_kinematics.ik(self.scene, robot_id, position, quat_xyzw, seed, collision_free,
                                     salt=self._ik_salt)

    def tracker(self, robot_id: str, position_tolerance: float,
                orientation_tolerance: float) -> inverse_kinematics.Tracker:
        return inverse_kinematics.tracker(self.scene, robot_id, position_tolerance, orientation_tolerance)

    # collision queries
    def collision_free_batch(self, robot_id: str, qs: npt.NDArray[np.float64],
                             bounds: bool = True) -> npt.NDArray[np.bool_]:
        return self.queries.free_batch(robot_id, qs, bounds)

    def motion_clearance(self, robot_id: str, *through: JointVector) -> float:
        return pathcheck.motion_clearance(self.scene, robot_id, *through)

    def check_step(self, robot_id: str, q_from: JointVector, q_to: JointVector,
                   clearance: float) -> CollisionReport:
        return pathcheck.check_step(self.scene, robot_id, q_from, q_to, clearance)

    # paths: timing, checks, detours
    def plan_motion(self, robot_id: str, target: JointVector, start: JointVector | None = None,
                    speed: float = DEFAULT_SPEED, dt: float = DEFAULT_DT, via: Sequence[JointVector] = (),
                    *, acceleration: float = DEFAULT_ACCELERATION, arc: Sequence[float] = (),
                    tcp_speed: float | None = DEFAULT_TCP_SPEED,
                    along: trajectory.Along | None = None,
                    tcp: Sequence[Sequence[float]] | None = None) -> TimedPath:
        return trajectory.plan_motion(self.scene, robot_id, target, start, speed, dt, via,
                                      acceleration=acceleration, arc=arc, tcp_speed=tcp_speed, along=along,
                                      tcp=tcp)

    def check_path(self, robot_id: str, target: JointVector, start: JointVector | None = None,
                   speed: float = DEFAULT_SPEED, dt: float = DEFAULT_DT,
                   via: Sequence[JointVector] = ()) -> PathReport:
        return pathcheck.check_path(self.scene, robot_id, target, start, speed, dt, via)

    def check_states(self, robot_id: str, path: TimedPath) -> PathReport:
        return pathcheck.check_states(self.scene, robot_id, path)

    def detour(self, robot_id: str, target: JointVector,
               budget: float = detours.BUDGET) -> builtins.list[tuple[float, ...]] | None:
        return detours.detour(self.scene, robot_id, target, self._detours, budget)

    # files
    def export_robot(self, robot_id: str, out_dir: str | Path) -> dict[str, Any]:
        """Write a self-contained copy of the robot's URDF (meshes under ``meshes/``) into ``out_dir``."""
        return self.export_job(robot_id, out_dir)()

    def export_job(self, robot_id: str, out_dir: str | Path) -> Callable[[], dict[str, Any]]:
        return export.export_job(self.scene.entry(robot_id), out_dir)
