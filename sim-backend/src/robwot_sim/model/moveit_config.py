"""A MoveIt config package as a robot: its URDF or xacro (with its xacro arguments), its SRDF and the
velocity limits of its ``config/joint_limits.yaml``.

Where the files are, in the order the MoveIt setup assistant records them:

* ``.setup_assistant`` (YAML, written by the setup assistant): ``URDF: {package, relative_path,
  xacro_args}`` and ``SRDF: {relative_path}``. The URDF's package is found as ``package://`` finds one
  (package roots, a package holding the config, ``ROS_PACKAGE_PATH``), then among the config package's
  sibling folders (a workspace's ``src/`` holds both): it is returned as a package root.
* otherwise exactly one ``config/*.urdf.xacro`` / ``config/*.xacro`` / ``config/*.urdf`` (MoveIt 2's
  assistant writes ``config/<robot>.urdf.xacro``), else the ``robot_description`` parameter of a launch file
  (``launch/*.launch``, ``*.launch.xml``: ``command="xacro '$(find PKG)/urdf/robot.urdf.xacro' NAME:=VALUE"``
  or ``textfile="$(find PKG)/urdf/robot.urdf"``, as MoveIt 1's ``planning_context.launch`` has it; arguments
  whose value is itself a launch substitution are left to the xacro's defaults); and exactly one
  ``config/*.srdf``.

``joint_limits.yaml``: ``joint_limits: {JOINT: {has_velocity_limits: true, max_velocity: V,
has_acceleration_limits: true, max_acceleration: A, has_position_limits: true, min_position: L, max_position:
U}}`` (the position keys as ros2_control's joint limits have them); MoveIt plans with these instead of the
URDF's, so the twin does too (xacro_expand writes the velocities and positions into the expanded URDF, a
continuous joint given positions becoming revolute; the accelerations, which a URDF
cannot carry, go to twin.json and ``robot.load``).

The package is a jail, as a twin folder is (``confine.py``): every file read from it (``.setup_assistant``,
``config/*``, ``launch/*``) and the SRDF its ``relative_path`` names resolve inside the config folder after
symlinks, the URDF's ``relative_path`` (or a launch file's ``$(find PKG)/path``) inside that package;
anything else is refused with `PathEscape` naming the file and who named it. Files are read whole or
refused naming their size limit (YAML: ``yamlsafe.py``), never cut.
"""

from __future__ import annotations

import os
import re
import shlex
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from robwot_sim.errors import FileNotFound, UrdfError
from robwot_sim.limits import MAX_LIMITED_JOINTS
from robwot_sim.model import xmlsafe
from robwot_sim.model.confine import confine
from robwot_sim.model.ros_packages import (
    enclosing_packages,
    find_on_ros_package_path,
    package_name,
    packages_below,
)
from robwot_sim.model.yamlsafe import load_yaml
from robwot_sim.wholefile import TooLarge, read_whole

#: largest launch file read (MoveIt's planning_context.launch is a few KiB)
MAX_LAUNCH_BYTES = 1024 * 1024


@dataclass(frozen=True)
class MoveitConfig:
    urdf: Path
    xacro_args: dict[str, str]
    srdf: Path
    package_roots: dict[str, str]
    #: the velocity and acceleration limits of its joint_limits.yaml
    limits: JointLimits

    def to_json(self) -> dict[str, Any]:
        return {"urdf": str(self.urdf), "xacroArgs": self.xacro_args, "srdf": str(self.srdf),
                "packageRoots": self.package_roots, "velocityLimits": self.limits.velocities,
                "accelerationLimits": self.limits.accelerations, "jerkLimits": self.limits.jerks,
                "positionLimits": {k: list(v) for k, v in self.limits.positions.items()}}


def _in_package(path: Path, package: Path, named_by: str) -> Path:
    """``path``'s real path when it stays inside ``package`` (after symlinks), else `PathEscape`."""
    return confine(path, [package], reason=f"{named_by} must stay inside the package folder {package}")


def _one(folder: Path, patterns: tuple[str, ...], what: str, config: Path) -> Path:
    for pattern in patterns:
        found = sorted(folder.glob(pattern))
        if len(found) == 1:
            return _in_package(found[0], config, f"the MoveIt config's {what} file {found[0].name}")
        if len(found) > 1:
            raise UrdfError(f"MoveIt config: several {what} files ({', '.join(p.name for p in found)}); "
                            "give the robot file itself instead of --moveit-config", file=str(folder))
    raise FileNotFound(str(folder / patterns[0]), what=f"MoveIt config {what} file")


def _package(name: str, config: Path, roots: Mapping[str, str], named_by: Path) -> Path:
    if name in roots:
        return Path(roots[name]).expanduser().resolve()
    hit = (enclosing_packages(config).get(name) or find_on_ros_package_path(name)
           or packages_below(config.parent).get(name))
    if hit is None:
        raise FileNotFound(name, what=f"ROS package {name!r} named by {named_by} (give --package-root "
                           f"{name}=DIR or add the folder it is in to ROS_PACKAGE_PATH)")
    return hit.resolve()


def _config_robot_file(config: Path) -> tuple[Path, dict[str, str]] | None:
    try:
        return _one(config / "config", ("*.urdf.xacro", "*.xacro", "*.urdf"), "URDF/xacro", config), {}
    except FileNotFound:
        return None


_FIND = re.compile(r"\$\(find ([A-Za-z0-9_]+)\)/([^\s'\"]+?\.(?:urdf\.xacro|xacro|urdf))")


def _launch_robot_description(config: Path, roots: dict[str, str]) -> tuple[Path, dict[str, str]] | None:
    """The file (and literal xacro arguments) of the first ``robot_description`` parameter in the config's
    launch files that names one with ``$(find PKG)/...``; the package is added to ``roots``."""
    files = sorted((config / "launch").glob("*.launch")) + sorted((config / "launch").glob("*.launch.xml"))
    for f in files:
        f = _in_package(f, config, f"the launch file {f.name}")
        try:
            root, _ = xmlsafe.parse(read_whole(f, MAX_LAUNCH_BYTES))
        except TooLarge as e:
            raise UrdfError(f"launch file: {e}", file=str(f), size=e.size, limit=e.limit) from None
        except (OSError, xmlsafe.XmlRefused, xmlsafe.XmlMalformed):
            continue  # not a launch file we can read: the next one may say it
        for el in root.iter("param"):
            name = el.get("name", "")
            spec = el.get("command") or el.get("textfile") or ""
            m = _FIND.search(spec)
            if "robot_description" not in name or "semantic" in name or m is None:
                continue
            pkg = _package(m.group(1), config, roots, f)
            roots[m.group(1)] = str(pkg)
            args = {}
            for token in shlex.split(spec[m.end():].replace("'", " ").replace('"', " ")):
                arg, sep, value = token.partition(":=")
                if sep and arg and "$(" not in value:
                    args[arg] = value
            return _in_package(pkg / m.group(2), pkg, f"{f}'s robot_description {m.group(0)!r}"), args
    return None


@dataclass(frozen=True)
class JointLimits:
    """What a ``joint_limits.yaml`` says: joint -> max velocity (rad/s or m/s), joint -> max acceleration
    (rad/s^2 or m/s^2), joint -> (min, max) position (rad or m), joint -> max jerk (rad/s^3 or m/s^3), each
    only for the joints whose ``has_..._limits`` is true."""

    velocities: dict[str, float]
    accelerations: dict[str, float]
    positions: dict[str, tuple[float, float]]
    jerks: dict[str, float] = field(default_factory=dict)


def joint_limits(file: Path, *, required: bool = False) -> JointLimits:
    """The velocity, acceleration and position limits of a MoveIt / ros2_control ``joint_limits.yaml``. A
    missing file gives none, or FileNotFound when ``required`` (``robwot generate --limits FILE``)."""
    if not file.is_file():
        if required:
            raise FileNotFound(str(file), what="joint limits file")
        return JointLimits({}, {}, {})
    doc = load_yaml(file)
    table = doc.get("joint_limits") if isinstance(doc, dict) else None
    if not isinstance(table, dict):
        raise UrdfError("no joint_limits: mapping", file=str(file))
    if len(table) > MAX_LIMITED_JOINTS:
        # its limits are handed on whole (robot.expandXacro, robot.load): a robot has tens of joints, and
        # the contract takes at most this many
        raise UrdfError(f"joint_limits names {len(table)} joints, more than the {MAX_LIMITED_JOINTS} a robot "
                        "may have limits for: refused whole", file=str(file), joints=len(table),
                        limit=MAX_LIMITED_JOINTS)
    out = JointLimits({}, {}, {})
    for joint, limits in table.items():
        if not isinstance(limits, dict):
            continue
        for flag, key, into in (("has_velocity_limits", "max_velocity", out.velocities),
                                ("has_acceleration_limits", "max_acceleration", out.accelerations),
                                ("has_jerk_limits", "max_jerk", out.jerks)):
            if limits.get(flag) and key in limits:
                into[str(joint)] = _number(file, joint, key, limits[key], positive=True)
        if limits.get("has_position_limits"):
            lower, upper = (_number(file, joint, key, limits.get(key))
                            for key in ("min_position", "max_position"))
            if not lower < upper:
                raise UrdfError(f"joint {joint!r}: min_position {lower!r} must be below max_position "
                                f"{upper!r}", file=str(file), joint=str(joint))
            out.positions[str(joint)] = (lower, upper)
    return out


def _number(file: Path, joint: object, key: str, v: object, *, positive: bool = False) -> float:
    """A limit's value: a number, positive where ``positive``, within 10^4 (rad, m, and per second)."""
    if not isinstance(v, int | float) or isinstance(v, bool) or not -1e4 < float(v) < 1e4 \
            or (positive and not float(v) > 0):
        raise UrdfError(f"joint {joint!r}: {key} {v!r} must be a {'positive ' if positive else ''}number "
                        "within 10^4", file=str(file), joint=str(joint))
    return float(v)


def find_moveit_config(folder: str | Path, package_roots: Mapping[str, str] | None = None) -> MoveitConfig:
    """The robot a MoveIt config package describes (see the module docstring). Raises FileNotFound (a
    file or package not there, naming what to give) or UrdfError (several candidates, bad YAML)."""
    config = Path(folder).expanduser()
    if not config.is_dir():
        raise FileNotFound(str(config), what="MoveIt config folder")
    config = config.resolve()
    roots = dict(package_roots or {})
    own = package_name(config)
    if own is not None:
        roots.setdefault(own, str(config))
    assistant = config / ".setup_assistant"
    urdf: Path | None = None
    srdf: Path | None = None
    xacro_args: dict[str, str] = {}
    if os.path.lexists(assistant):
        doc = load_yaml(_in_package(assistant, config, "the MoveIt config's .setup_assistant"))
        setup = doc.get("moveit_setup_assistant_config") if isinstance(doc, dict) else None
        setup = setup if isinstance(setup, dict) else {}
        u, s = setup.get("URDF") or {}, setup.get("SRDF") or {}
        if isinstance(u, dict) and u.get("package") and u.get("relative_path"):
            pkg = _package(str(u["package"]), config, roots, assistant)
            roots[str(u["package"])] = str(pkg)
            urdf = _in_package(pkg / str(u["relative_path"]), pkg,
                               f"{assistant}'s URDF relative_path {str(u['relative_path'])!r}")
            for arg in shlex.split(str(u.get("xacro_args") or "")):
                name, sep, value = arg.partition(":=")
                if not sep or not name:
                    raise UrdfError(f"xacro_args: {arg!r} is not NAME:=VALUE", file=str(assistant))
                xacro_args[name] = value
        if isinstance(s, dict) and s.get("relative_path"):
            srdf = _in_package(config / str(s["relative_path"]), config,
                               f"{assistant}'s SRDF relative_path {str(s['relative_path'])!r}")
    if urdf is None:
        found = _config_robot_file(config) or _launch_robot_description(config, roots)
        if found is None:
            raise FileNotFound(str(config / "config" / "*.urdf.xacro"),
                               what="MoveIt config URDF/xacro file (no .setup_assistant, no "
                               "config/*.urdf.xacro|*.xacro|*.urdf, no robot_description in launch/*.launch)")
        urdf, launch_args = found
        xacro_args.update(launch_args)
    srdf = srdf or _one(config / "config", ("*.srdf",), "SRDF", config)
    for f, what in ((urdf, "URDF/xacro"), (srdf, "SRDF")):
        if not f.is_file():
            raise FileNotFound(str(f), what=f"MoveIt config {what} file")
    limits_file = config / "config" / "joint_limits.yaml"
    if os.path.lexists(limits_file):
        limits_file = _in_package(limits_file, config, "the MoveIt config's config/joint_limits.yaml")
    limits = joint_limits(limits_file)
    return MoveitConfig(urdf, xacro_args, srdf, roots, limits)
