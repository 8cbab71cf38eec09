"""ROS packages found the way ROS finds them: a folder is the package NAME when its ``package.xml`` says
``<name>NAME</name>``.

Three places are searched, beside the caller's explicit ``NAME -> DIR`` roots: the ancestors of a file (the
package that holds a URDF or a xacro file), the folders of ``ROS_PACKAGE_PATH`` (colon-separated), each
crawled as ``rospack`` does: a folder with a ``package.xml`` is a package and is not descended into,
folders holding ``CATKIN_IGNORE``/``COLCON_IGNORE``/``AMENT_IGNORE`` and hidden folders are skipped, and the
ROS 2 install prefixes of ``AMENT_PREFIX_PATH`` (``PREFIX/share/NAME``).

Robot descriptions copied out of a ROS workspace often lost their ``package.xml`` (the paper's robots: a
``dobot_description`` folder holding ``urdf/`` and ``meshes/``). For them, and only when no manifest names
the package, ``folder_named`` takes a folder that has the package's name and holds the file, or stands
beside a folder holding it, within ``MAX_NAMED_LEVELS`` of the file's folder; never the filesystem root,
its direct children (``/tmp``, ``/home``) or the home folder and its ancestors, where a folder that merely
has the name is not the robot's; never a folder whose ``package.xml`` names another package.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

from robwot_sim.errors import UrdfError
from robwot_sim.model import xmlsafe
from robwot_sim.wholefile import TooLarge, read_whole

#: how deep below a ROS_PACKAGE_PATH folder packages are looked for (a workspace's src/group/pkg fits)
MAX_DEPTH = 6
IGNORE_MARKERS = ("CATKIN_IGNORE", "COLCON_IGNORE", "AMENT_IGNORE")
#: largest package.xml read (a real one is a few KiB)
MAX_MANIFEST_BYTES = 64 * 1024
#: how many folders above a file's own folder a folder taken by its name may be (pkg/urdf/xacro/robot.xacro
#: fits)
MAX_NAMED_LEVELS = 3


def package_name(folder: Path) -> str | None:
    """The ``<name>`` declared by ``folder/package.xml``, or None (no manifest, or not a readable one). A
    manifest above ``MAX_MANIFEST_BYTES`` is refused (`UrdfError` naming it and the limit), never read in
    part."""
    manifest = folder / "package.xml"
    try:
        data = read_whole(manifest, MAX_MANIFEST_BYTES) if manifest.is_file() else b""
    except TooLarge as e:
        raise UrdfError(f"ROS package manifest: {e}", file=str(manifest), size=e.size,
                        limit=e.limit) from None
    except OSError:
        return None
    if not data:
        return None
    try:
        declared = xmlsafe.parse(data)[0].findtext("name")
    except (xmlsafe.XmlRefused, xmlsafe.XmlMalformed):
        return None  # not a readable manifest: not a package
    return declared.strip() if declared is not None and declared.strip() else None


def enclosing_package(start: Path, name: str) -> Path | None:
    """The ancestor of ``start`` (itself included) that is the ROS package ``name``, if any."""
    for anc in [start, *start.parents]:
        if anc.name == name:
            return anc if package_name(anc) == name else None
    return None


def enclosing_packages(start: Path) -> dict[str, Path]:
    """Every ROS package among the ancestors of ``start`` (itself included), by name; the nearest wins."""
    found: dict[str, Path] = {}
    for anc in [start, *start.parents]:
        name = package_name(anc)
        if name is not None and name not in found:
            found[name] = anc
    return found


def ros_package_path() -> tuple[Path, ...]:
    """The existing folders of ``ROS_PACKAGE_PATH``, in order (empty entries and missing folders skipped)."""
    entries = os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep)
    return tuple(Path(p).expanduser().resolve() for p in entries
                 if p.strip() and Path(p).expanduser().is_dir())


@lru_cache(maxsize=16)
def packages_below(folder: Path) -> dict[str, Path]:
    """Packages below one ROS_PACKAGE_PATH folder by name; the first found (breadth first) wins. Read once
    per backend process and folder, as rospack caches its crawl."""
    found: dict[str, Path] = {}
    level = [folder]
    for _ in range(MAX_DEPTH + 1):
        nxt: list[Path] = []
        for d in level:
            if any((d / m).exists() for m in IGNORE_MARKERS):
                continue
            name = package_name(d)
            if name is not None:
                found.setdefault(name, d)
                continue  # a package's sub-folders hold no other package
            try:
                subs = sorted(e for e in d.iterdir() if e.is_dir() and not e.name.startswith("."))
            except OSError:
                continue
            nxt += subs
        level = nxt
    return found


def find_on_ros_package_path(name: str) -> Path | None:
    """The package ``name`` from the ROS_PACKAGE_PATH folders (the first folder holding it wins), else from
    the install prefixes of ``AMENT_PREFIX_PATH`` (ROS 2: ``PREFIX/share/NAME`` with its package.xml, as
    ament_index finds it), or None."""
    for folder in ros_package_path():
        hit = packages_below(folder).get(name)
        if hit is not None:
            return hit.resolve()
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        share = Path(prefix) / "share" / name if prefix else None
        if share is not None and share.is_dir() and package_name(share) == name:
            return share.resolve()
    return None


def _too_general(folder: Path) -> bool:
    """The filesystem root, a direct child of it, or the home folder or one of its ancestors: a folder there
    that merely has a package's name is not the robot's."""
    if len(folder.parts) <= 2:
        return True
    try:
        home = Path.home().resolve()
    except (RuntimeError, OSError):
        return False
    return folder == home or folder in home.parents


def folder_named(start: Path, name: str) -> Path | None:
    """The folder taken as ROS package ``name`` by its name alone (no ``package.xml`` names it anywhere: the
    caller asks the manifests first): the nearest ancestor of ``start`` (itself included, at most
    ``MAX_NAMED_LEVELS`` above it) named ``name``, else the nearest folder named ``name`` beside one of
    those ancestors. A folder whose ``package.xml`` names another package, or one ``_too_general``, is
    never taken. ``start`` should be resolved; a sibling is returned as written (not resolved), so the
    caller's confinement refuses a symlinked sibling that leads elsewhere."""
    if not name or name in (".", ".."):
        return None
    ancestors = [start, *start.parents][: MAX_NAMED_LEVELS + 1]

    def fits(folder: Path) -> bool:
        return (folder.is_dir() and not _too_general(folder)
                and package_name(folder) in (None, name))

    for anc in ancestors:
        if anc.name == name and fits(anc):
            return anc
    for anc in ancestors:
        sibling = anc.parent / name
        if anc.parent != anc and sibling != anc and fits(sibling):
            return sibling
    return None
