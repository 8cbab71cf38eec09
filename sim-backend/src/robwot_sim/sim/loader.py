"""Loading a URDF into a PyBullet client: checks first, then the body, joint model and collision filter."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pybullet as pb

from robwot_sim.errors import FileNotFound, InvalidParams, UnknownLink, UrdfError
from robwot_sim.limits import CLEARANCE, DEFAULT_CLEARANCE
from robwot_sim.model.couplings import passive_notes
from robwot_sim.model.decompose import OnMesh
from robwot_sim.model.joints import UrdfModel, parse_model
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.model.srdf import read_srdf
from robwot_sim.model.urdf import PreparedUrdf, UrdfDoc, parse_urdf, prepare_urdf, pybullet_data_path
from robwot_sim.sim.client import Bullet
from robwot_sim.sim.collision import BodyTable, CollisionChecker, find_always_colliding
from robwot_sim.sim.kinematics import reach_sphere
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.sweep import Guard, joint_reach
from robwot_sim.sim.types import FloatArray

FILTER_SEED = 12345


@dataclass
class RobotEntry:
    model: RobotModel
    bound: BoundRobot
    checker: CollisionChecker
    urdf_path: Path
    package_roots: dict[str, str]
    collision_parts: tuple[Path, ...]
    #: per controllable joint, how far the farthest collision point travels per unit of motion (sweep.py)
    reach: FloatArray
    #: a sphere (centre, radius; m, world) holding every end-effector position (kinematics.reach_sphere)
    sphere: tuple[FloatArray, float]
    #: clearance (m) its paths and motions keep to other bodies (sweep.Guard)
    clearance: float = DEFAULT_CLEARANCE
    #: the URDF as PyBullet loaded it (meshes checked, absolute, concave ones split, visuals dropped): a
    #: body of the robot with a link added is built from it without reading its files again (gripper.py)
    loaded_urdf: str = ""

    @property
    def guard(self) -> Guard:
        return Guard(self.reach, self.clearance)


def resolve_urdf_path(urdf: str | Path, base: Path | None = None) -> Path:
    """An existing URDF file: absolute, relative to ``base`` (default cwd), else relative to pybullet_data."""
    p = Path(urdf).expanduser()
    cands = [p] if p.is_absolute() else [(base or Path.cwd()) / p, pybullet_data_path() / p]
    for c in cands:
        if c.is_file():
            return c.resolve()
    raise FileNotFound(str(cands[0]), what="URDF file")


def _check_collision_shapes(bullet: Bullet, bound: BoundRobot, doc: UrdfDoc, meshes: dict[str, Path]) -> None:
    """PyBullet silently drops meshes it cannot read: refuse a link whose collision geometry vanished."""
    for el in doc.root.findall("link"):
        if el.find("collision") is None:
            continue
        idx = bound.link_index.get(el.get("name", ""))
        if idx is not None and not bullet.has_collision_shape(bound.body, idx):
            files = [m.get("filename", "") for m in el.iter("mesh")]
            raise UrdfError(
                f"PyBullet could not read the collision geometry of link {el.get('name')!r} "
                f"({', '.join(files) or 'no mesh'})",
                file=str(doc.file),
                line=doc.line_of(el),
                link=el.get("name"),
                meshes=[str(meshes.get(f, f)) for f in files],
            )


def _clear_pair_filters(bullet: Bullet, bound: BoundRobot) -> None:
    """Every pair of the new body's links checked as PyBullet checks a new body's (adjacent links never):
    PyBullet keeps a removed body's pair filters under its id, and a new body given that id would inherit
    them (its always-colliding pairs then went unfound, yet filtered, or another robot's filtered)."""
    for a, b in itertools.combinations(sorted(bound.link_names), 2):
        bullet.set_pair_filter(bound.body, bound.body, a, b, True)


@dataclass
class RobotFiles:
    """A robot's files read, checked and prepared for PyBullet (meshes parsed, concave ones split into
    convex parts): all the work of a load that needs no world, so it runs off the world's thread.
    ``cleanup()`` once loaded (or given up)."""

    path: Path
    doc: UrdfDoc
    urdf_model: UrdfModel
    ee: str
    srdf_path: Path | None
    srdf_pairs: frozenset[tuple[str, str]]
    prepared: PreparedUrdf
    package_roots: dict[str, str]
    #: what the user should know of the load: a package taken by its folder's name, SRDF entries skipped
    notes: tuple[str, ...] = ()
    #: links never put among the always-colliding pairs (a held object: contacts it makes in every
    #: random configuration are contacts to check, not a design overlap)
    always_checked: frozenset[str] = frozenset()
    #: the robot's filtered pairs already known (a body of it rebuilt with a link added, gripper.py):
    #: taken as the always-colliding ones, nothing sampled (pairs with ``always_checked`` links excepted)
    always_colliding: frozenset[tuple[str, str]] | None = None

    def cleanup(self) -> None:
        self.prepared.cleanup()


def _geometry_notes(doc: UrdfDoc) -> list[str]:
    """A URDF whose links have no ``<collision>`` at all: nothing of the robot can be checked."""
    if any(link.find("collision") is not None for link in doc.root.findall("link")):
        return []
    return [f"{doc.file}: no link has <collision> geometry, so every configuration is collision-free to the "
            "twin (self-collisions and obstacles alike): add <collision> elements (e.g. copies of the "
            "<visual> ones) before trusting its verdicts"]


def _linkage_notes(doc: UrdfDoc, model: UrdfModel) -> list[str]:
    """What looks like a passive joint of a linkage no coupling covers (``couplings.passive_notes``)."""
    transmitted = {el.get("name", "") for t in doc.root.findall("transmission") for el in t.findall("joint")}
    stated = {el.get("name", "") for el in doc.root.findall("joint")
              if (lim := el.find("limit")) is not None and lim.get("velocity") is not None}
    return passive_notes(str(doc.file), model.joints,
                         {j.name: j.velocity for j in model.joints if j.name in stated},
                         {j.name: j.origin_xyz for j in model.joints}, transmitted,
                         {c.follower for c in model.couplings})


def read_robot_files(
    urdf: str | Path,
    ee_link: str | None,
    package_roots: Mapping[str, str],
    base_dir: Path | None = None,
    srdf: str | Path | None = None,
    decompose: bool = True,
    on_mesh: OnMesh | None = None,
    *,
    couplings: Sequence[str] = (),
    keep_level: Sequence[str] = (),
) -> RobotFiles:
    """Check the URDF (and SRDF) completely and prepare it for PyBullet; touches no PyBullet client.

    With ``decompose`` False a concave collision mesh without cached convex parts is refused (MeshError)."""
    path = resolve_urdf_path(urdf, base_dir)
    for name, folder in package_roots.items():
        if not Path(folder).expanduser().is_dir():
            raise FileNotFound(str(folder), what=f"package root {name!r} folder")
    doc = parse_urdf(path)
    urdf_model = parse_model(doc).coupled(couplings, keep_level)
    ee = ee_link if ee_link is not None else urdf_model.default_ee()
    if ee not in urdf_model.links:
        raise UnknownLink(ee, urdf_model.links)
    srdf_path = Path(srdf).expanduser().resolve() if srdf is not None else None
    joints = [j.name for j in urdf_model.joints]
    semantic = read_srdf(srdf_path, urdf_model.links, joints) if srdf_path is not None else None
    prepared = prepare_urdf(path, package_roots, doc, decompose=decompose, on_mesh=on_mesh)
    notes = (*prepared.notes, *(semantic.warnings if semantic else ()), *_linkage_notes(doc, urdf_model),
             *_geometry_notes(doc))
    return RobotFiles(path, doc, urdf_model, ee, srdf_path, semantic.disabled if semantic else frozenset(),
                      prepared, dict(package_roots), notes)


def load_robot_body(
    bullet: Bullet,
    table: BodyTable,
    files: RobotFiles,
    robot_id: str,
    base_position: list[float],
    base_orientation: list[float],
) -> RobotEntry:
    """Create the body of checked robot files (`read_robot_files`). Nothing is left in the client on
    error; the files' temporary copy is removed either way.

    The SRDF's ``<disable_collisions>`` pairs join the filtered pairs: never checked anywhere."""
    path, doc, urdf_model, ee, prepared = files.path, files.doc, files.urdf_model, files.ee, files.prepared
    srdf_path, srdf_pairs, package_roots = files.srdf_path, files.srdf_pairs, files.package_roots
    try:
        flags = pb.URDF_USE_SELF_COLLISION
        try:
            loaded = prepared.bullet_path.read_text(encoding="utf-8")
            body = bullet.load_urdf(str(prepared.bullet_path), base_position, base_orientation, flags)
        except pb.error as e:
            raise UrdfError(f"PyBullet could not load the URDF: {e}", file=str(path)) from None
    finally:
        prepared.cleanup()
    try:
        bound = BoundRobot(bullet, body, urdf_model, ee)
        _check_collision_shapes(bullet, bound, doc, prepared.meshes)
        _clear_pair_filters(bullet, bound)
        checked = {bound.link_index[name] for name in files.always_checked}
        known = files.always_colliding
        always = (find_always_colliding(bound, np.random.default_rng(FILTER_SEED)) if known is None
                  else [(bound.link_index[a], bound.link_index[b]) for a, b in sorted(known)])
        filtered = [p for p in always if not checked.intersection(p)]
        filtered += [(bound.link_index[a], bound.link_index[b]) for a, b in sorted(srdf_pairs)]
        checker = CollisionChecker(bound, table, filtered)
    except Exception:
        bullet.remove_body(body)
        raise
    names = bound.link_names
    model = RobotModel(
        id=robot_id,
        name=urdf_model.name,
        urdf=str(path),
        ee_link=ee,
        links=urdf_model.links,
        joints=urdf_model.joints,
        controllable=urdf_model.controllable,
        filtered_pairs=tuple((names[a], names[b]) for a, b in sorted(checker.filtered)),
        base_position=(base_position[0], base_position[1], base_position[2]),
        base_orientation=(base_orientation[0], base_orientation[1], base_orientation[2], base_orientation[3]),
        package_roots=dict(package_roots),
        srdf=str(srdf_path) if srdf_path is not None else None,
        couplings=urdf_model.couplings,
    )
    return RobotEntry(model, bound, checker, path, dict(package_roots), prepared.collision_parts,
                      joint_reach(bound), reach_sphere(bound), loaded_urdf=loaded)


def load_limits(movable: Sequence[str], clearance: float, accelerations: Mapping[str, float],
                jerks: Mapping[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """A load's ``clearance`` (m) checked, then its acceleration and jerk limits (``acceleration_limits``)."""
    # above 0 for the sweep bound to hold (sweep.py); at most the farthest distance at which Bullet reports
    # other bodies (its contact breaking threshold)
    if clearance not in CLEARANCE:
        within = f"[{CLEARANCE.minimum}, {CLEARANCE.maximum}]"
        raise InvalidParams(f"clearance must be in {within} m", param="clearance",
                            expected=f"number in {within}", got=clearance)
    return acceleration_limits(movable, accelerations), acceleration_limits(movable, jerks, "jerkLimits")


def acceleration_limits(movable: Sequence[str], given: Mapping[str, float],
                        param: str = "accelerationLimits") -> dict[str, float]:
    """``given`` (the request's ``param``: acceleration or jerk limits) checked: each a movable joint's, a
    positive finite number."""
    out: dict[str, float] = {}
    for joint, value in given.items():
        if joint not in movable:
            raise InvalidParams(f"{param}: {joint!r} is not a movable joint of the robot",
                                param=param, expected=list(movable), got=joint)
        if isinstance(value, bool) or not isinstance(value, int | float) or not 0 < value < math.inf:
            raise InvalidParams(f"{param}: {joint!r} must be a positive number, got {value!r}",
                                param=param, expected="positive number", got=value)
        out[joint] = float(value)
    return out
