"""The simulation world: one PyBullet DIRECT client holding robots and static obstacles."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.sim.types import CollisionReport, IkResult, PathReport, Pose, RobotModel

Vec3 = Sequence[float]
Quat = Sequence[float]


class World:
    """Robots + obstacles in one PyBullet DIRECT client. Context manager; call ``close()``.

    Every method validates its input before touching the world: a failed call changes nothing.
    """

    def __init__(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        raise NotImplementedError

    # robots
    def load_robot(self, urdf: str | Path, *, robot_id: str | None = None,
                   base_position: Vec3 = (0.0, 0.0, 0.0), base_orientation: Quat = (0.0, 0.0, 0.0, 1.0),
                   ee_link: str | None = None, package_roots: Mapping[str, str] | None = None) -> RobotModel:
        raise NotImplementedError

    def remove_robot(self, robot_id: str) -> None:
        raise NotImplementedError

    def robot_model(self, robot_id: str) -> RobotModel:
        raise NotImplementedError

    def robot_ids(self) -> list[str]:
        raise NotImplementedError

    # scene / obstacles
    def load_scene(self, scene: dict[str, Any] | str | Path,
                   package_roots: Mapping[str, str] | None = None) -> dict[str, Any]:
        """Load a scene document (dict) or file; returns ``{"robots": [id], "obstacles": [name]}``."""
        raise NotImplementedError

    def add_obstacle(self, spec: dict[str, Any]) -> dict[str, Any]:
        raise NotImplementedError

    def move_obstacle(self, name: str, position: Vec3, orientation: Quat | None = None,
                      rpy: Vec3 | None = None) -> dict[str, Any]:
        raise NotImplementedError

    def remove_obstacle(self, name: str) -> None:
        raise NotImplementedError

    def list(self) -> dict[str, Any]:
        raise NotImplementedError

    def reset(self) -> None:
        raise NotImplementedError

    def scene_spec(self) -> dict[str, Any]:
        raise NotImplementedError

    # joints / kinematics
    def get_joint_positions(self, robot_id: str) -> npt.NDArray[np.float64]:
        raise NotImplementedError

    def set_joint_positions(self, robot_id: str, q: Sequence[float] | npt.NDArray[np.float64]) -> None:
        raise NotImplementedError

    def fk(self, robot_id: str, q: Sequence[float] | npt.NDArray[np.float64] | None = None) -> Pose:
        raise NotImplementedError

    def ik(self, robot_id: str, position: Vec3, quat_xyzw: Quat | None = None,
           seed: Sequence[float] | None = None, collision_free: bool = True) -> IkResult:
        raise NotImplementedError

    # collision
    def check_collision(self, robot_id: str,
                        q: Sequence[float] | npt.NDArray[np.float64] | None = None) -> CollisionReport:
        raise NotImplementedError

    def collision_free_batch(self, robot_id: str, qs: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        raise NotImplementedError

    # motion (planning only)
    def plan_motion(self, robot_id: str, target: Sequence[float], start: Sequence[float] | None = None,
                    speed: float = 1.0, dt: float = 1.0 / 240.0) -> npt.NDArray[np.float64]:
        raise NotImplementedError

    def check_path(self, robot_id: str, target: Sequence[float], start: Sequence[float] | None = None,
                   speed: float = 1.0, dt: float = 1.0 / 240.0) -> PathReport:
        raise NotImplementedError

    def export_robot(self, robot_id: str, out_dir: str | Path) -> dict[str, Any]:
        raise NotImplementedError
