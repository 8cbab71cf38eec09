"""World scene: static obstacles, scene documents and the scene of the current world."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from robwot_sim import validate as v
from robwot_sim.errors import InvalidParams, MeshError, UnknownObject
from robwot_sim.model.meshcheck import check_mesh, mesh_points
from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.scene import normalise_obstacle, read_scene, resolve_file
from robwot_sim.sim.client import HULL
from robwot_sim.sim.loader import RobotFiles
from robwot_sim.sim.world_base import Quat, Vec3, WorldBase, _owned

#: an obstacle spec as stored (normalised) and the shape PyBullet loads (a checked, maybe converted, mesh)
ReadObstacle = tuple[dict[str, Any], dict[str, Any]]
#: the most hull vertices PyBullet is handed as a list (its command buffer refuses far larger lists)
MAX_HULL_POINTS = 40_000


@dataclass
class SceneFiles:
    """A scene read and checked off the world's thread (``WorldScene.read_scene``): its obstacles with
    their meshes parsed, its robots' files prepared. ``cleanup()`` once added (or given up)."""

    obstacles: list[ReadObstacle]
    robots: list[tuple[dict[str, Any], RobotFiles]] = field(default_factory=list)

    def cleanup(self) -> None:
        for _, files in self.robots:
            files.cleanup()


def read_obstacle(spec: Any, base: Path | None = None, *, checked: bool = False) -> ReadObstacle:
    """An obstacle spec normalised (``scene.normalise_obstacle``) and, for a mesh, the mesh parsed by our
    own reader (PyBullet crashes on some broken meshes) and its convex hull computed: work that needs no
    world, any thread."""
    norm = normalise_obstacle(spec, base, checked=checked)
    shape = norm["shape"]
    if shape["type"] == "mesh":
        try:
            shape = {**shape, "file": str(check_mesh(Path(shape["file"])))}
            hull = mesh_hull(Path(shape["file"]), shape.get("scale", 1.0))
        except MeshError as e:
            name = norm["name"]
            raise MeshError(f"obstacle {name!r}: {e.message}", obstacle=name, **e.data) from None
        if hull is not None:
            shape = {**shape, HULL: hull}
    return norm, shape


def mesh_hull(path: Path, scale: float | list[float]) -> list[list[float]] | None:
    """The vertices of the convex hull of a mesh obstacle (scaled), the shape PyBullet gives a mesh body:
    computed here, off the world's thread, so the world only builds a hull of these few points (PyBullet
    building it from the whole mesh holds the interpreter for as long). None for a mesh we do not read
    (DAE) or whose hull has more vertices than PyBullet takes as a list: PyBullet then reads the file."""
    raw = mesh_points(path)
    if raw is None:
        return None
    points = raw * np.asarray(scale, dtype=np.float64)
    try:
        hull = ConvexHull(points)
    except QhullError:  # flat or degenerate: the joggled hull keeps every point it needs
        hull = ConvexHull(points, qhull_options="QJ")
    if len(hull.vertices) > MAX_HULL_POINTS:
        return None
    return [[float(c) for c in p] for p in points[hull.vertices]]


class WorldScene(WorldBase):
    """Obstacles and scenes on top of ``WorldBase``."""

    @staticmethod
    def read_scene(
        scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None,
        decompose: bool = True,
    ) -> SceneFiles:
        """The part of ``load_scene`` that needs no world (any thread): the document read and validated,
        obstacle meshes parsed, each robot's files prepared (``read_robot``; with ``decompose`` False a
        concave mesh without cached parts is refused instead of decomposed)."""
        if not isinstance(scene, (dict, str, Path)):
            raise InvalidParams(
                "scene must be an object or a file path", param="scene", expected="object", got=scene
            )
        roots = v.string_map("packageRoots", package_roots)
        doc, base, _file = read_scene(scene)
        out = SceneFiles([read_obstacle(o, base, checked=True) for o in doc.get("obstacles", [])])
        try:
            for r in doc.get("robots", []):
                files = WorldBase.read_robot(
                    r["urdf"], robot_id=r.get("id"), ee_link=r.get("eeLink"),
                    package_roots={**roots, **r.get("packageRoots", {})},
                    srdf=resolve_file(r["srdf"], base, what="SRDF file") if "srdf" in r else None,
                    decompose=decompose, _base_dir=base)
                out.robots.append((r, files))
        except Exception:
            out.cleanup()
            raise
        return out

    @_owned
    def load_scene(
        self, scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None
    ) -> dict[str, Any]:
        """Add a scene's obstacles and robots, all or nothing: ``{"robots": [id], "obstacles": [name]}``.
        = ``read_scene`` then ``add_scene``."""
        return self.add_scene(self.read_scene(scene, package_roots))

    @_owned
    def add_scene(self, files: SceneFiles) -> dict[str, Any]:
        """Add a read scene (``read_scene``), all or nothing; removes the robots' temporary copies."""
        added_obs: list[str] = []
        added_rob: list[str] = []
        try:
            for spec, _ in files.obstacles:
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
        except Exception:  # all or nothing: undo what this scene added
            for rid in added_rob:
                self.remove_robot(rid)
            for name in added_obs:
                self.remove_obstacle(name)
            raise
        finally:
            files.cleanup()
        return {"robots": added_rob, "obstacles": added_obs}

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

    @_owned
    def add_obstacle(self, spec: dict[str, Any] | ReadObstacle) -> dict[str, Any]:
        """Add a static obstacle ``{name, shape, position, orientation? | rpy?}`` (or one already read by
        ``read_obstacle``, off the world's thread); returns it normalised."""
        return self._add_obstacle(spec if isinstance(spec, tuple) else read_obstacle(spec))

    @_owned
    def move_obstacle(
        self, name: str, position: Vec3, orientation: Quat | None = None, rpy: Vec3 | None = None
    ) -> dict[str, Any]:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        pos = v.position("position", position)
        if orientation is not None and rpy is not None:
            raise InvalidParams(
                "give orientation or rpy, not both", param="rpy", expected="one of them", got=rpy
            )
        body, spec = self._obstacles[name]
        if orientation is not None:
            quat = v.quaternion("orientation", orientation)
        elif rpy is not None:
            quat = list(quat_from_rpy(v.position("rpy", rpy)))
        else:
            quat = list(spec["orientation"])
        self.bullet.reset_base(body, pos, quat)
        spec = {**spec, "position": pos, "orientation": quat}
        self._obstacles[name] = (body, spec)
        self._changed()
        return spec

    @_owned
    def remove_obstacle(self, name: str) -> None:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        body, _ = self._obstacles.pop(name)
        self._built.pop(name, None)
        self.bullet.remove_body(body)
        del self.table.names[body]
        self._changed()

    @_owned
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

    @_owned
    def reset(self) -> None:
        """Remove every robot and obstacle."""
        for rid in list(self._robots):
            self.remove_robot(rid)
        for name in list(self._obstacles):
            self.remove_obstacle(name)

    @_owned
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
            if e.model.srdf:
                r["srdf"] = e.model.srdf
            if e.package_roots:
                r["packageRoots"] = {
                    k: str(Path(p).expanduser().resolve()) for k, p in e.package_roots.items()
                }
            robots.append(r)
        return {"version": 1, "obstacles": [spec for _, spec in self._obstacles.values()], "robots": robots}
