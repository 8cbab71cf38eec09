"""What adding bodies to a scene needs and no world does: a robot's files, an obstacle's mesh and a scene
document read, checked and prepared on any thread, so the world's thread only creates the bodies
(``planning_scene.Scene.add_robot`` / ``add_obstacle`` / ``add_scene``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robwot_sim import validate as v
from robwot_sim.errors import InvalidParams, MeshError
from robwot_sim.model.decompose import OnMesh
from robwot_sim.model.meshcheck import check_mesh, mesh_points
from robwot_sim.scene import normalise_obstacle, resolve_file
from robwot_sim.scene import read_scene as read_scene_document
from robwot_sim.sim.client import HULL
from robwot_sim.sim.conveyors import Conveyor, read_conveyor
from robwot_sim.sim.loader import RobotFiles, read_robot_files
from robwot_sim.sim.sensors import Sensor, read_sensor

#: an obstacle spec as stored (normalised) and the shape PyBullet loads (a checked, maybe converted, mesh)
ReadObstacle = tuple[dict[str, Any], dict[str, Any]]
#: the most hull vertices PyBullet is handed as a list (its command buffer refuses far larger lists)
MAX_HULL_POINTS = 40_000


@dataclass
class SceneFiles:
    """A scene read and checked off the world's thread (``read_scene``): its obstacles and objects with
    their meshes parsed, its robots' files prepared. ``cleanup()`` once added (or given up)."""

    obstacles: list[ReadObstacle]
    robots: list[tuple[dict[str, Any], RobotFiles]] = field(default_factory=list)
    objects: list[ReadObstacle] = field(default_factory=list)
    #: the conveyors' own state (their belts are among ``obstacles``, ``cell.py``) and the sensors
    conveyors: list[Conveyor] = field(default_factory=list)
    sensors: list[Sensor] = field(default_factory=list)

    def cleanup(self) -> None:
        for _, files in self.robots:
            files.cleanup()


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
    couplings: Sequence[str] = (),
    keep_level: Sequence[str] = (),
) -> RobotFiles:
    """The part of a load that needs no world (any thread): params checked, URDF/SRDF read (with the
    ``couplings`` rules and the ``keep_level`` links' rules, ``model/couplings.py``), meshes
    parsed, concave ones split into convex parts (minutes for a robot's first load). ``Scene.add_robot``
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
    return read_robot_files(urdf, ee_link, roots, _base_dir, srdf, decompose, on_mesh,
                            couplings=couplings, keep_level=keep_level)


def read_obstacle(spec: Any, base: Path | None = None, *, checked: bool = False,
                  kind: str = "obstacles") -> ReadObstacle:
    """An obstacle spec normalised (``scene.normalise_obstacle``) and, for a mesh, the mesh parsed by our
    own reader (PyBullet crashes on some broken meshes) and its convex hull computed: work that needs no
    world, any thread. ``kind="objects"``: an object's spec (with its mass)."""
    norm = normalise_obstacle(spec, base, checked=checked, kind=kind)
    shape = norm["shape"]
    if shape["type"] == "mesh":
        try:
            shape = {**shape, "file": str(check_mesh(Path(shape["file"])))}
            hull = mesh_hull(Path(shape["file"]), shape.get("scale", 1.0))
        except MeshError as e:
            name = norm["name"]
            what = "obstacle" if kind == "obstacles" else "object"
            raise MeshError(f"{what} {name!r}: {e.message}", obstacle=name, **e.data) from None
        if hull is not None:
            shape = {**shape, HULL: hull}
    return norm, shape


def read_object(spec: Any, base: Path | None = None, *, checked: bool = False) -> ReadObstacle:
    """An object spec read as an obstacle's (``read_obstacle``), normalised with its mass (kg)."""
    return read_obstacle(spec, base, checked=checked, kind="objects")


def mesh_hull(path: Path, scale: float | list[float]) -> list[list[float]] | None:
    """The vertices of the convex hull of a mesh obstacle (scaled), the shape PyBullet gives a mesh body:
    computed here, off the world's thread, so the world only builds a hull of these few points (PyBullet
    building it from the whole mesh holds the interpreter for as long). None for a mesh we do not read
    (DAE) or whose hull has more vertices than PyBullet takes as a list: PyBullet then reads the file."""
    raw = mesh_points(path)
    if raw is None:
        return None
    points = raw * np.asarray(scale, dtype=np.float64)
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except QhullError:  # flat or degenerate: the joggled hull keeps every point it needs
        hull = ConvexHull(points, qhull_options="QJ")
    if len(hull.vertices) > MAX_HULL_POINTS:
        return None
    return [[float(c) for c in p] for p in points[hull.vertices]]


def read_scene(
    scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None,
    decompose: bool = True,
) -> SceneFiles:
    """The part of ``Scene.load_scene`` that needs no world (any thread): the document read and validated,
    obstacle meshes parsed, each robot's files prepared (``read_robot``; with ``decompose`` False a
    concave mesh without cached parts is refused instead of decomposed)."""
    if not isinstance(scene, (dict, str, Path)):
        raise InvalidParams(
            "scene must be an object or a file path", param="scene", expected="object", got=scene
        )
    roots = v.string_map("packageRoots", package_roots)
    doc, base, _file = read_scene_document(scene)
    conveyors = [read_conveyor(c) for c in doc.get("conveyors", [])]
    obstacles = [*doc.get("obstacles", []), *(belt for _, belt in conveyors)]
    out = SceneFiles([read_obstacle(o, base, checked=True) for o in obstacles],
                     objects=[read_object(o, base, checked=True) for o in doc.get("objects", [])],
                     conveyors=[c for c, _ in conveyors],
                     sensors=[read_sensor(s) for s in doc.get("sensors", [])])
    try:
        for r in doc.get("robots", []):
            files = read_robot(
                r["urdf"], robot_id=r.get("id"), ee_link=r.get("eeLink"),
                package_roots={**roots, **r.get("packageRoots", {})},
                srdf=resolve_file(r["srdf"], base, what="SRDF file") if "srdf" in r else None,
                decompose=decompose, _base_dir=base, couplings=r.get("couplings", ()))
            out.robots.append((r, files))
    except Exception:
        out.cleanup()
        raise
    return out
