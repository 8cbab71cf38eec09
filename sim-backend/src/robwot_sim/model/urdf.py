"""Safe URDF reading, mesh path resolution with root confinement, and self-contained export.

* No DTD, no entities: a document containing ``<!DOCTYPE`` or ``<!ENTITY`` is refused before parsing
  (XXE, billion laughs), and the expat parser refuses them again if they slip through an encoding.
* Mesh filenames are resolved (``package://``, relative, absolute) and must stay inside the allowed roots:
  the URDF folder, user package roots, package folders found as ancestors of the URDF (or, without a
  ``package.xml``, by their folder's name: ``ros_packages.folder_named``), ``pybullet_data``.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pybullet_data

from robwot_sim.errors import (
    FileNotFound,
    Forbidden,
    MeshError,
    PathEscape,
    UnknownPackage,
    UrdfError,
    snippet,
)
from robwot_sim.model import xmlsafe
from robwot_sim.model.confine import inside
from robwot_sim.model.decompose import FloatArray, IndexArray, OnMesh, collision_cache, split_collisions
from robwot_sim.model.meshcheck import check_mesh, read_mesh
from robwot_sim.model.ros_packages import enclosing_package, find_on_ros_package_path, folder_named
from robwot_sim.wholefile import TooLarge, read_whole

MAX_URDF_BYTES = 20 * 1024 * 1024
MESH_SUFFIXES = (".stl", ".obj", ".dae")


def pybullet_data_path() -> Path:
    return Path(pybullet_data.getDataPath()).resolve()


@dataclass
class UrdfDoc:
    """A parsed URDF: root element, its source file, and the source line of each element."""

    root: ET.Element
    file: Path
    lines: dict[int, int] = field(default_factory=dict)

    def line_of(self, el: ET.Element) -> int | None:
        return self.lines.get(id(el))


def parse_xml(path: str | Path, *, root_tag: str, error: type[UrdfError], what: str) -> UrdfDoc:
    """Read and parse a robot description file (URDF, SRDF) safely: no DTD, no entities, a size limit,
    the expected root element. Raises FileNotFound, Forbidden or ``error`` (with file, line, column)."""
    p = Path(path).expanduser()
    if not p.is_file():
        raise FileNotFound(str(p), what=what)
    p = p.resolve()
    try:
        data = read_whole(p, MAX_URDF_BYTES)
    except TooLarge as e:
        raise error(str(e), file=str(p), size=e.size, limit=e.limit) from None
    try:
        root, lines = xmlsafe.parse(data)
    except xmlsafe.XmlRefused as e:
        raise Forbidden(
            f"{p}:{e.line}: XML {e.what} declarations are refused (no DTD or entities in a {what})",
            file=str(p),
            line=e.line,
        ) from None
    except xmlsafe.XmlMalformed as e:
        raise error(e.reason, file=str(p), line=e.line, column=e.column) from None
    if root.tag != root_tag:
        raise error(
            f"root element is {snippet(root.tag)}, expected <{root_tag}>", file=str(p),
            line=lines.get(id(root)),
        )
    return UrdfDoc(root, p, lines)


def _triangles(path: Path) -> tuple[FloatArray, IndexArray] | None:
    mesh = read_mesh(path)
    return None if mesh is None else (mesh.vertices, mesh.faces)


#: what xacro would have substituted: ``${expression}`` and ``$(command args)``
_XACRO = re.compile(r"\$[{(]")


def refuse_unexpanded(doc: UrdfDoc) -> None:
    """A ``${...}`` or ``$(...)`` left in any attribute or text is a xacro file read as a URDF: refused
    (UrdfError with file and line) before any number is parsed, so the user is told what it is instead of
    "expected 3 numbers", and nothing passes unchecked in geometry no number parser reads. Comments are not
    part of the tree and may hold anything."""
    for el in doc.root.iter():
        found = [(f"attribute {k!r} of <{el.tag}>", v) for k, v in el.attrib.items() if _XACRO.search(v)]
        found += [(f"the text of <{el.tag}>", t) for t in (el.text, el.tail) if t and _XACRO.search(t)]
        if found:
            where, value = found[0]
            raise UrdfError(
                f"unexpanded xacro {snippet(value.strip(), 80)} in {where}: a xacro file? name it .xacro or "
                "pass it as robot.urdf.xacro (robwot generate expands it; --xacro-arg NAME:=VALUE sets its "
                "args)",
                file=str(doc.file), line=doc.line_of(el), code="E_URDF",
            )


def parse_urdf(path: str | Path) -> UrdfDoc:
    """Read and parse a URDF file safely. Raises FileNotFound, Forbidden or UrdfError (also for xacro
    left unexpanded: ``refuse_unexpanded``)."""
    doc = parse_xml(path, root_tag="robot", error=UrdfError, what="URDF file")
    refuse_unexpanded(doc)
    return doc


def read_urdf(path: str | Path) -> ET.Element:
    """Contract 5: the root ``<robot>`` element of a URDF file, read safely."""
    return parse_urdf(path).root


def allowed_roots(urdf_dir: Path, package_roots: Mapping[str, str | Path] | None) -> list[Path]:
    roots = [urdf_dir.resolve(), pybullet_data_path()]
    roots += [Path(r).expanduser().resolve() for r in (package_roots or {}).values()]
    return roots


def resolve_mesh(
    filename: str,
    urdf_dir: str | Path,
    package_roots: Mapping[str, str | Path] | None = None,
    *,
    urdf: str | None = None,
    line: int | None = None,
    notes: dict[str, str] | None = None,
) -> Path:
    """Resolve a URDF mesh filename to an existing absolute path inside the allowed roots.

    ``package://NAME/rest`` (NAME must not be empty) is looked up in ``package_roots[NAME]``, then in the
    ROS package NAME that holds the URDF (an ancestor folder with a ``package.xml`` naming NAME), then in
    the package NAME found on ``ROS_PACKAGE_PATH`` and ``AMENT_PREFIX_PATH`` (ros_packages.py); when none
    of these knows NAME, in the folder named NAME that holds the URDF or stands beside a folder holding it
    (``ros_packages.folder_named``; ``notes[NAME]`` then says so, once per package); then
    ``pybullet_data/NAME``, then the URDF folder (PyBullet's own rule, used by pybullet_data's panda).
    ``file://`` and absolute paths are taken as is; others are relative to the URDF folder. Raises
    PathEscape when the result leaves the allowed roots (``..``, symlinks), UnknownPackage when NAME is
    found nowhere and no fallback file exists (naming the option that fixes it), FileNotFound when
    missing. ``line`` is the referencing element's line in ``urdf``.
    """
    udir = Path(urdf_dir).resolve()
    roots = allowed_roots(udir, package_roots)
    pkg_roots = {k: Path(v).expanduser().resolve() for k, v in (package_roots or {}).items()}
    candidates: list[Path] = []
    extra_roots: list[Path] = []
    by_name: tuple[Path, str, str] | None = None  # (candidate, package, note): a package taken by its name
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        name, _, sub = rest.partition("/")
        if not name or name in (".", ".."):
            raise PathEscape(filename, [str(r) for r in roots], urdf=urdf,
                             reason="package:// needs a package name (package://NAME/path)")
        if name in pkg_roots:
            candidates.append(pkg_roots[name] / sub)
        for package in (enclosing_package(udir, name), find_on_ros_package_path(name)):
            if package is not None:
                candidates.append(package / sub)
                extra_roots.append(package)
        named = folder_named(udir, name) if name not in pkg_roots and not extra_roots else None
        if named is not None:
            note = _named_note(filename, name, named, urdf, line)
            by_name = (Path(os.path.normpath(named / sub)), name, note)
            candidates.append(by_name[0])
            extra_roots.append(named)
        known = bool(name in pkg_roots or extra_roots or (pybullet_data_path() / name).is_dir())
        candidates.append(pybullet_data_path() / name / sub)
        candidates.append(udir / name / sub)
        candidates.append(udir / sub)
    elif filename.startswith("file://"):
        candidates.append(Path(filename[len("file://") :]))
    else:
        fp = Path(filename)
        candidates.append(fp if fp.is_absolute() else udir / fp)
    roots = roots + extra_roots
    resolved = [Path(os.path.normpath(c)) for c in candidates]
    for c in resolved:
        if not inside(c, roots):
            continue
        if c.is_file():
            real = c.resolve()  # follow symlinks: they must not lead out either
            if not inside(real, roots):
                raise PathEscape(str(real), [str(r) for r in roots], urdf=urdf)
            if by_name is not None and c == by_name[0] and notes is not None:
                notes.setdefault(by_name[1], by_name[2])
            return real
    if filename.startswith("package://") and not known:
        raise UnknownPackage(filename, filename[len("package://"):].partition("/")[0], urdf=urdf, line=line,
                             searched=[str(c) for c in resolved if inside(c, roots)])
    within = [c for c in resolved if inside(c, roots)]
    if not within:
        raise PathEscape(str(resolved[0]), [str(r) for r in roots], urdf=urdf)
    raise FileNotFound(
        str(within[0]),
        urdf=urdf,
        what=f"mesh file {filename!r}",
        reference=filename,
        searched=[str(c) for c in within],
    )


def _named_note(filename: str, name: str, folder: Path, urdf: str | None, line: int | None) -> str:
    """What the user is told when a package was taken by its folder's name: where, and how to choose."""
    where = f"{urdf}:{line}: " if urdf and line is not None else f"{urdf}: " if urdf else ""
    return (f"{where}{filename}: no package.xml names ROS package {name!r}; taken as the folder {folder} by "
            f"its name (give --package-root {name}=DIR to choose another)")


@dataclass
class PreparedUrdf:
    """A URDF checked and rewritten for PyBullet: absolute mesh paths, visuals stripped."""

    doc: UrdfDoc
    bullet_path: Path
    meshes: dict[str, Path]  # original filename -> checked absolute path PyBullet loads
    tmpdir: str
    collision_parts: tuple[Path, ...] = ()  # convex decomposition cache folders used (see decompose.py)
    #: what the user should know of how the meshes were found (a package taken by its folder's name)
    notes: tuple[str, ...] = ()

    def cleanup(self) -> None:
        shutil.rmtree(self.tmpdir, ignore_errors=True)


def prepare_urdf(
    path: str | Path, package_roots: Mapping[str, str | Path] | None = None, doc: UrdfDoc | None = None,
    *, decompose: bool = True, on_mesh: OnMesh | None = None,
) -> PreparedUrdf:
    """Resolve every mesh (visual and collision) and write a temp URDF PyBullet can load as is.

    Visual elements are dropped from the temp copy (DIRECT mode never renders them). With ``decompose``
    False a concave collision mesh must already have its convex parts in the cache (a twin folder's
    ``collision/``), else MeshError: nothing is decomposed. ``on_mesh`` hears of each mesh decomposed.
    """
    doc = doc or parse_urdf(path)
    udir = doc.file.parent
    meshes: dict[str, Path] = {}
    notes: dict[str, str] = {}
    root = ET.fromstring(ET.tostring(doc.root))
    for el in doc.root.iter("mesh"):
        fn = el.get("filename")
        if not fn:
            raise UrdfError("<mesh> without filename", file=str(doc.file), line=doc.line_of(el))
        if fn not in meshes:
            resolved = resolve_mesh(fn, udir, package_roots, urdf=str(doc.file), line=doc.line_of(el),
                                    notes=notes)
            if resolved.suffix.lower() not in MESH_SUFFIXES:
                raise UrdfError(
                    f"unsupported mesh format {snippet(resolved.suffix)} ({snippet(fn, 200, quote=False)}); "
                    "use STL, OBJ or DAE",
                    file=str(doc.file),
                    line=doc.line_of(el),
                )
            try:  # PyBullet crashes on some broken meshes: our parser reads each one first
                meshes[fn] = check_mesh(resolved)
            except MeshError as e:
                raise MeshError(f"{doc.file}:{doc.line_of(el)}: {e.message}", urdf=str(doc.file),
                                line=doc.line_of(el), **e.data) from None
    for link in root.iter("link"):
        for vis in list(link.findall("visual")):
            link.remove(vis)
    tmpdir = tempfile.mkdtemp(prefix="robwot-urdf-")
    for el in root.iter("mesh"):
        el.set("filename", str(meshes[el.get("filename", "")]))
    # PyBullet would turn each concave collision mesh into one convex hull: split it into convex parts
    parts = split_collisions(root, collision_cache(udir), _triangles, allow_decompose=decompose,
                             on_mesh=on_mesh)
    return PreparedUrdf(doc, _write_for_bullet(root, Path(tmpdir)), meshes, tmpdir, parts,
                        tuple(notes.values()))


def _write_for_bullet(root: ET.Element, tmpdir: Path) -> Path:
    """The URDF file PyBullet loads, one element per line. PyBullet breaks long lines of a URDF, even
    mid-attribute ("cannot find 'eb06...982\\nc/part081.obj'", then "Cannot load URDF file"): the convex
    parts of a link (decompose.py), written on one line, loaded at 30 parts (a 3.4 KB line) and failed at
    100 (10 KB), whatever the file's size (a 111 KB URDF with short lines loads)."""
    ET.indent(root)
    out = tmpdir / "robot.urdf"
    ET.ElementTree(root).write(out, encoding="utf-8", xml_declaration=True)
    return out
