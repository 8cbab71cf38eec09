"""An object a gripper holds written into the robot's URDF: a fixed link on the end effector, named as the
object, its collision geometry the object's shape as the scene built it (``sim/gripper.py``).

Two trees get the link: a portable copy of the robot's own URDF (``tool.portable_copy``: it loads from any
folder; the mirror worlds read it) and the URDF as PyBullet loaded the robot (meshes already checked and
split: the body holding the object is built from it without reading the robot's files again). A mesh
object's geometry is its convex hull, written as an OBJ beside the URDF, named by its absolute path so
that both trees find it.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pybullet as pb

from robwot_sim.model.objfile import write_obj
from robwot_sim.model.tool import fixed_joint, link_element, portable_copy
from robwot_sim.model.urdf import UrdfDoc

if TYPE_CHECKING:
    from scipy.spatial import ConvexHull

#: the key of a mesh shape's hull points in a shape as built (``sim/client.py`` ``HULL``)
HULL = "hull"

Offset = tuple[Sequence[float], Sequence[float]]


def held_geometry(shape: Mapping[str, Any], folder: Path, name: str) -> ET.Element:
    """A URDF ``<geometry>`` of an object's shape as built: a box, sphere or cylinder as it is, a mesh as
    its convex hull (the points ``shape[HULL]``), written as ``folder/<name>_hull.obj``."""
    geometry = ET.Element("geometry")
    t = shape["type"]
    if t == "box":
        ET.SubElement(geometry, "box", {"size": " ".join(f"{v:.9g}" for v in shape["size"])})
    elif t == "sphere":
        ET.SubElement(geometry, "sphere", {"radius": f"{shape['radius']:.9g}"})
    elif t == "cylinder":
        ET.SubElement(geometry, "cylinder", {"radius": f"{shape['radius']:.9g}",
                                             "length": f"{shape['length']:.9g}"})
    else:
        from scipy.spatial import ConvexHull

        points = np.asarray(shape[HULL], dtype=np.float64)
        out = folder / f"{name}_hull.obj"
        write_obj(out, points, outward(points, ConvexHull(points)))
        ET.SubElement(geometry, "mesh", {"filename": str(out.resolve())})
    return geometry


def outward(points: np.ndarray, hull: ConvexHull) -> list[tuple[int, int, int]]:
    """The hull's triangles wound outward (their normal away from the hull's centre)."""
    centre = points[hull.vertices].mean(axis=0)
    out = []
    for a, b, c in hull.simplices:
        n = np.cross(points[b] - points[a], points[c] - points[a])
        out.append((int(a), int(b), int(c)) if n @ (points[a] - centre) >= 0 else (int(a), int(c), int(b)))
    return out


def held_link_name(root: ET.Element, name: str) -> str:
    """The held link's name: the object's, unless the robot has a link of that name (then ``held_`` +
    name)."""
    links = {el.get("name") for el in root.findall("link")}
    return name if name not in links else f"held_{name}"


def add_held(root: ET.Element, ee: str, link_name: str, geometry: ET.Element, offset: Offset) -> None:
    """``root`` with the link ``link_name`` of collision ``geometry`` fixed on ``ee`` at ``offset``
    (position, quaternion ``[x, y, z, w]`` in the end effector's frame), its joint ``<link>_grasp``."""
    link = link_element(root, link_name)
    ET.SubElement(link, "collision").append(geometry)
    rpy = pb.getEulerFromQuaternion(offset[1])
    root.append(fixed_joint(f"{link_name}_grasp", ee, link_name, offset[0], rpy))


def write_urdf(root: ET.Element, out: Path) -> Path:
    """``root`` written to ``out``, one element per line."""
    ET.indent(root)
    ET.ElementTree(root).write(out, encoding="utf-8", xml_declaration=True)
    return out


@dataclass(frozen=True)
class HeldUrdf:
    """A robot's URDF with a held object written (``held_urdf``): the link's name, the end effector it is
    fixed on at ``offset``, its collision geometry, the portable copy's file and package roots."""

    link: str
    ee: str
    offset: Offset
    geometry: ET.Element
    urdf: Path
    package_roots: dict[str, str]

    def add_to(self, text: str, out: Path) -> Path:
        """Another URDF of the same robot (``text``: as PyBullet loaded it) with the same link, written to
        ``out``."""
        root = ET.fromstring(text)
        add_held(root, self.ee, self.link, copy.deepcopy(self.geometry), self.offset)
        return write_urdf(root, out)


def held_urdf(doc: UrdfDoc, roots: Mapping[str, str], ee: str, name: str, shape: Mapping[str, Any],
              offset: Offset, folder: Path) -> HeldUrdf:
    """The robot's URDF ``doc`` with object ``name`` (its shape as built) as a fixed link on ``ee`` at
    ``offset``, a portable copy written into ``folder`` under the URDF's own file name."""
    root, held_roots = portable_copy(doc, roots)
    link_name = held_link_name(root, name)
    geometry = held_geometry(shape, folder, link_name)
    add_held(root, ee, link_name, copy.deepcopy(geometry), offset)
    out = write_urdf(root, folder / doc.file.name)
    return HeldUrdf(link_name, ee, offset, geometry, out, held_roots)
