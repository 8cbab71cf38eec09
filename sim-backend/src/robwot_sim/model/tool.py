"""A tool on the robot's end effector, written into the URDF as ROS users mount one.

``attach_tool`` writes a copy of a URDF with two fixed links added below the end-effector link (the
flange): ``robwot_tool``, carrying the tool's mesh and/or a box or cylinder as visual and collision
geometry (optional), and
``robwot_tcp``, the tool centre point at its offset from the flange. The TCP link then is the end effector:
every Cartesian affordance, the workspace samples, the STL and the reachability map refer to it; the tool
is a collision body of the robot like its links, checked against the scene and the other links, except
against the flange it is mounted on (a fixed joint: adjacent links are never checked, as an SRDF's
"Adjacent" pairs). The copy goes into a new temporary folder (the caller deletes it) with the tool's mesh
beside it and the URDF's relative mesh paths made absolute (its folder becomes a package root).
"""

from __future__ import annotations

import shutil
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robwot_sim.errors import FileNotFound, UnknownLink, UrdfError
from robwot_sim.model.joints import parse_model
from robwot_sim.model.meshcheck import check_mesh
from robwot_sim.model.urdf import UrdfDoc, parse_urdf, resolve_mesh

TOOL_LINK = "robwot_tool"
TCP_LINK = "robwot_tcp"
#: the package root under which the source URDF's folder is passed on (its relative meshes now absolute)
URDF_FOLDER_ROOT = "robwot.urdf-folder"


@dataclass(frozen=True)
class AttachedTool:
    urdf: Path
    package_roots: dict[str, str]
    flange: str
    tcp_link: str


def link_element(parent: ET.Element, name: str) -> ET.Element:
    """A link with a nominal inertial (PyBullet warns of links without one; fixed links carry no dynamics
    here: DIRECT mode only checks collisions)."""
    link = ET.SubElement(parent, "link", {"name": name})
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", {"value": "0.001"})
    ET.SubElement(inertial, "inertia", {"ixx": "1e-6", "ixy": "0", "ixz": "0", "iyy": "1e-6", "iyz": "0",
                                        "izz": "1e-6"})
    return link


def fixed_joint(name: str, parent: str, child: str, xyz: Sequence[float], rpy: Sequence[float]) -> ET.Element:
    joint = ET.Element("joint", {"name": name, "type": "fixed"})
    ET.SubElement(joint, "parent", {"link": parent})
    ET.SubElement(joint, "child", {"link": child})
    ET.SubElement(joint, "origin", {"xyz": " ".join(f"{v:.9g}" for v in xyz),
                                    "rpy": " ".join(f"{v:.9g}" for v in rpy)})
    return joint


def _primitive(shape: Mapping[str, Any]) -> tuple[ET.Element, float]:
    """A URDF ``<geometry>`` of a box (``size`` [x, y, z]) or cylinder (``radius``, ``length``) and its
    length along z: the shape extends from the flange along its z axis (centred at half its length)."""
    geometry = ET.Element("geometry")
    if shape["type"] == "box":
        sx, sy, sz = (float(v) for v in shape["size"])
        ET.SubElement(geometry, "box", {"size": f"{sx:.9g} {sy:.9g} {sz:.9g}"})
        return geometry, sz
    radius, length = float(shape["radius"]), float(shape["length"])
    ET.SubElement(geometry, "cylinder", {"radius": f"{radius:.9g}", "length": f"{length:.9g}"})
    return geometry, length


def portable_copy(doc: UrdfDoc, package_roots: Mapping[str, str]) -> tuple[ET.Element, dict[str, str]]:
    """A copy of a URDF's tree that loads from any folder, and the package roots to load it with: relative
    mesh paths made absolute, each ``package://`` package's folder a root of its name, the URDF's folder
    the root ``URDF_FOLDER_ROOT``."""
    root = ET.fromstring(ET.tostring(doc.root))
    roots = {**package_roots, URDF_FOLDER_ROOT: str(doc.file.parent)}
    for el in root.iter("mesh"):
        fn = el.get("filename", "")
        real = resolve_mesh(fn, doc.file.parent, package_roots, urdf=str(doc.file))
        if fn.startswith("package://"):
            # the package stays found from the copy's folder: its folder becomes a root of its name
            name, _, rest = fn[len("package://"):].partition("/")
            folder = real
            for _ in Path(rest).parts:
                folder = folder.parent
            roots.setdefault(name, str(folder))
        elif not fn.startswith("file://") and not Path(fn).is_absolute():
            el.set("filename", str(real))
    return root, roots


def attach_tool(urdf: str | Path, package_roots: Mapping[str, str], ee_link: str | None,
                tcp: Sequence[float], mesh: str | Path | None = None,
                shape: Mapping[str, Any] | None = None) -> AttachedTool:
    """The URDF with the tool mounted on ``ee_link`` (default: the URDF's default end effector). ``tcp``:
    X, Y, Z (m), ROLL, PITCH, YAW (rad, fixed axes as a URDF ``<origin rpy>``) of the TCP in the flange's
    frame. ``mesh``: the tool's STL, OBJ or DAE in the flange's frame (checked by our mesh parser);
    ``shape``: a box or cylinder from the flange along its z axis (``_primitive``); both may be given.
    Raises UnknownLink, UrdfError (the URDF already has the tool's links), FileNotFound, MeshError."""
    doc = parse_urdf(urdf)
    model = parse_model(doc)
    flange = ee_link if ee_link is not None else model.default_ee()
    if flange not in model.links:
        raise UnknownLink(flange, model.links)
    for name in (TOOL_LINK, TCP_LINK):
        if name in model.links:
            raise UrdfError(f"the URDF already has a link named {name!r}: a tool was attached to it before "
                            "(attach the tool to the original URDF)", file=str(doc.file))
    tool_mesh = None
    if mesh is not None:
        tool_mesh = Path(mesh).expanduser()
        if not tool_mesh.is_file():
            raise FileNotFound(str(tool_mesh), what="tool mesh")
        check_mesh(tool_mesh.resolve())
    root, roots = portable_copy(doc, package_roots)
    out_dir = Path(tempfile.mkdtemp(prefix="robwot-tool-"))
    parent = flange
    if tool_mesh is not None or shape is not None:
        link = link_element(root, TOOL_LINK)
        if tool_mesh is not None:
            copied = out_dir / f"{TOOL_LINK}{tool_mesh.suffix.lower()}"
            shutil.copyfile(tool_mesh, copied)
            for kind in ("visual", "collision"):
                geometry = ET.SubElement(ET.SubElement(link, kind), "geometry")
                ET.SubElement(geometry, "mesh", {"filename": copied.name})
        if shape is not None:
            for kind in ("visual", "collision"):
                geometry, length = _primitive(shape)
                element = ET.SubElement(link, kind)
                ET.SubElement(element, "origin", {"xyz": f"0 0 {length / 2:.9g}", "rpy": "0 0 0"})
                element.append(geometry)
        root.append(fixed_joint(f"{TOOL_LINK}_mount", flange, TOOL_LINK, (0, 0, 0), (0, 0, 0)))
        parent = TOOL_LINK
    link_element(root, TCP_LINK)
    root.append(fixed_joint(f"{TCP_LINK}_joint", parent, TCP_LINK, tcp[:3], tcp[3:6]))
    out = out_dir / doc.file.name
    ET.indent(root)
    ET.ElementTree(root).write(out, encoding="utf-8", xml_declaration=True)
    return AttachedTool(out, roots, flange, TCP_LINK)
