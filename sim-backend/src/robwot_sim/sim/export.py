"""Self-contained copy of a robot: ``robot.urdf`` with relative mesh paths and the meshes beside it.

Meshes keep their folder layout below their common folder (``meshes/collision/link0.obj``,
``meshes/visual/link0.dae``), so names never clash; OBJ material libraries (``mtllib``) and COLLADA
images (``<init_from>``) found next to a mesh are copied too, so the viewer sees the same materials.
"""

from __future__ import annotations

import functools
import os
import re
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from robwot_sim.model.urdf import parse_urdf, resolve_mesh
from robwot_sim.sim.loader import RobotEntry
from robwot_sim.twin_layout import COLLISION_DIR, MESHES_DIR, URDF

_MTLLIB = re.compile(rb"^\s*mtllib\s+(.+?)\s*$", re.MULTILINE)
_MAPS = re.compile(rb"^\s*(?:map_\w+|bump|disp|decal)\s+(?:-\S+\s+\S+\s+)*(\S.*?)\s*$", re.MULTILINE)
_INIT_FROM = re.compile(rb"<init_from>\s*([^<]+?\.(?:png|jpe?g|bmp|tga|tiff?))\s*</init_from>", re.IGNORECASE)


def _companions(mesh: Path) -> list[Path]:
    """Files a mesh refers to (OBJ mtllib and its texture maps, DAE images) below the mesh's folder."""
    pattern = {".obj": _MTLLIB, ".mtl": _MAPS, ".dae": _INIT_FROM}.get(mesh.suffix.lower())
    if pattern is None:
        return []
    out = []
    for raw in pattern.findall(mesh.read_bytes()):
        name = raw.decode("utf-8", "replace").removeprefix("file://")
        p = Path(os.path.normpath(mesh.parent / name))
        if p.is_file() and mesh.parent in p.parents:
            out += [p, *(_companions(p) if p.suffix.lower() == ".mtl" else [])]
    return out


def _common_folder(paths: Iterable[Path]) -> Path:
    folders = [str(p.parent) for p in paths]
    return Path(os.path.commonpath(folders)) if folders else Path("/")


def export_urdf(
    path: str | Path,
    out_dir: str | Path,
    package_roots: Mapping[str, str | Path] | None = None,
    collision_parts: Sequence[Path] = (),
) -> dict[str, Any]:
    """Write ``out_dir/robot.urdf`` with meshes copied under ``out_dir/meshes/`` and relative filenames,
    and the robot's convex decompositions under ``out_dir/collision/`` (the cache a twin is loaded with).

    Returns ``{"urdf": "robot.urdf", "meshes": [relative paths]}`` (meshes referenced by the URDF).
    """
    doc = parse_urdf(path)
    out = Path(out_dir)
    root = ET.fromstring(ET.tostring(doc.root))
    sources: dict[str, Path] = {}
    for el in root.iter("mesh"):
        fn = el.get("filename", "")
        if fn not in sources:
            sources[fn] = resolve_mesh(fn, doc.file.parent, package_roots, urdf=str(doc.file))
    # meshes below the URDF's folder and the others (a mounted tool's copy sits beside meshes found
    # elsewhere) are each laid out below their group's common folder, so the twin never holds a copy of
    # the machine's absolute paths
    udir = doc.file.parent.resolve()
    beside = {fn: src for fn, src in sources.items() if udir in src.parents}
    others = {fn: src for fn, src in sources.items() if fn not in beside}
    common = {**{fn: _common_folder(beside.values()) for fn in beside},
              **{fn: _common_folder(others.values()) for fn in others}}
    mapping = {fn: (Path(MESHES_DIR) / src.relative_to(common[fn])).as_posix() for fn, src in sources.items()}
    placed: dict[str, Path] = {}
    for fn, target in mapping.items():  # one file per place (two names of one file share it)
        if placed.setdefault(target, sources[fn]) != sources[fn]:
            raise ValueError(f"{path}: meshes {placed[target]} and {sources[fn]} would both be copied to "
                             f"{target}")
    for fn, src in sources.items():
        for extra in [src, *_companions(src)]:
            dst = out / MESHES_DIR / extra.relative_to(common[fn])
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(extra, dst)
    for el in root.iter("mesh"):
        el.set("filename", mapping[el.get("filename", "")])
    out.mkdir(parents=True, exist_ok=True)
    for folder in collision_parts:
        shutil.copytree(folder, out / COLLISION_DIR / folder.name, dirs_exist_ok=True)
    ET.ElementTree(root).write(out / URDF, encoding="utf-8", xml_declaration=True)
    return {"urdf": URDF, "meshes": sorted(set(mapping.values()))}


def export_job(entry: RobotEntry, out_dir: str | Path) -> Callable[[], dict[str, Any]]:
    """The export (``export_urdf``) of a loaded robot as a function that needs no world: it only copies
    files (any thread)."""
    return functools.partial(export_urdf, entry.urdf_path, out_dir, entry.package_roots,
                             entry.collision_parts)
