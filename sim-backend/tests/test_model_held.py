"""A held object written into the robot's URDF (model/held.py): a fixed link named as the object on the end
effector at the grasp's offset, its geometry the object's shape (box, cylinder, sphere, a mesh's convex hull
as an OBJ wound outward); the portable copy loads from its folder, the same link goes into the URDF as
PyBullet loaded the robot."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robwot_sim.model.held import HULL, HeldUrdf, held_urdf
from robwot_sim.model.joints import parse_model
from robwot_sim.model.rotations import quat_matrix, rpy_matrix
from robwot_sim.model.urdf import parse_urdf, prepare_urdf, pybullet_data_path
from robwot_sim.sim import client

KUKA = pybullet_data_path() / "kuka_iiwa/model.urdf"
EE = "lbr_iiwa_link_7"
#: the object 12 cm along the flange's z, turned 90 degrees about its x axis
OFFSET = ((0.01, -0.02, 0.12), (0.7071067811865476, 0.0, 0.0, 0.7071067811865476))
CUBE = {"type": "box", "size": [0.04, 0.05, 0.06]}


def write(tmp_path: Path, shape: dict[str, Any], name: str = "cube") -> tuple[HeldUrdf, ET.Element]:
    written = held_urdf(parse_urdf(KUKA), {}, EE, name, shape, OFFSET, tmp_path)
    return written, ET.parse(written.urdf).getroot()


def link_and_joint(root: ET.Element, link: str) -> tuple[ET.Element, ET.Element]:
    [el] = [e for e in root.findall("link") if e.get("name") == link]
    [joint] = [j for j in root.findall("joint") if j.find("child").get("link") == link]  # type: ignore[union-attr]
    return el, joint


def test_the_object_is_a_link_fixed_on_the_end_effector_at_the_grasp(tmp_path: Path) -> None:
    written, root = write(tmp_path, CUBE)
    assert (written.link, written.ee, written.urdf) == ("cube", EE, tmp_path / KUKA.name)
    link, joint = link_and_joint(root, "cube")
    assert joint.get("name") == "cube_grasp" and joint.get("type") == "fixed"
    assert joint.find("parent").get("link") == EE  # type: ignore[union-attr]
    origin = joint.find("origin")
    assert origin is not None
    assert [float(v) for v in origin.get("xyz", "").split()] == pytest.approx(OFFSET[0])
    rpy = [float(v) for v in origin.get("rpy", "").split()]
    assert rpy_matrix(*rpy) == pytest.approx(quat_matrix(OFFSET[1]), abs=1e-8)  # 9 digits written
    assert link.find("visual") is None and link.find("inertial") is not None
    model = parse_model(parse_urdf(written.urdf))
    assert "cube" in model.links and model.controllable == parse_model(parse_urdf(KUKA)).controllable


def test_a_link_of_the_objects_name_makes_it_held_(tmp_path: Path) -> None:
    written, root = write(tmp_path, CUBE, name="lbr_iiwa_link_3")
    assert written.link == "held_lbr_iiwa_link_3"
    link_and_joint(root, "held_lbr_iiwa_link_3")


@pytest.mark.parametrize(("shape", "tag", "attributes"), [
    (CUBE, "box", {"size": "0.04 0.05 0.06"}),
    ({"type": "cylinder", "radius": 0.03, "length": 0.1}, "cylinder", {"radius": "0.03", "length": "0.1"}),
    ({"type": "sphere", "radius": 0.025}, "sphere", {"radius": "0.025"}),
])
def test_a_primitive_is_written_as_it_is(tmp_path: Path, shape: dict[str, Any], tag: str,
                                         attributes: dict[str, str]) -> None:
    _, root = write(tmp_path, shape)
    link, _ = link_and_joint(root, "cube")
    geometry = link.find("collision/geometry")
    assert geometry is not None and [g.tag for g in geometry] == [tag]
    assert geometry[0].attrib == attributes


def test_a_mesh_is_its_convex_hull_wound_outward(tmp_path: Path) -> None:
    """An octahedron's six corners and its centre (inside: not a hull vertex) as the shape's hull points."""
    points = [[0.05, 0, 0], [-0.05, 0, 0], [0, 0.05, 0], [0, -0.05, 0], [0, 0, 0.05], [0, 0, -0.05],
              [0, 0, 0]]
    written, root = write(tmp_path, {"type": "mesh", "file": "any.stl", HULL: points})
    link, _ = link_and_joint(root, "cube")
    mesh = link.find("collision/geometry/mesh")
    assert mesh is not None
    obj = Path(mesh.get("filename", ""))
    assert obj.is_absolute() and obj == (tmp_path / "cube_hull.obj").resolve()
    lines = obj.read_text().splitlines()
    v = np.array([[float(x) for x in ln.split()[1:]] for ln in lines if ln.startswith("v ")])
    faces = [[int(i) - 1 for i in ln.split()[1:]] for ln in lines if ln.startswith("f ")]
    assert v == pytest.approx(np.array(points)) and len(faces) == 8
    for a, b, c in faces:
        normal = np.cross(v[b] - v[a], v[c] - v[a])
        assert normal @ v[a] > 0  # away from the centre
    # the portable copy loads from its folder: every mesh found, the hull among them
    prepared = prepare_urdf(written.urdf, written.package_roots)
    try:
        assert obj in prepared.meshes.values()
    finally:
        prepared.cleanup()


def test_the_same_link_goes_into_the_urdf_pybullet_loaded(tmp_path: Path) -> None:
    written, root = write(tmp_path, CUBE)
    prepared = prepare_urdf(KUKA, {})
    try:
        out = written.add_to(prepared.bullet_path.read_text(), tmp_path / "loaded.urdf")
    finally:
        prepared.cleanup()
    loaded = ET.parse(out).getroot()
    link, joint = link_and_joint(loaded, "cube")
    portable_link, portable_joint = link_and_joint(root, "cube")
    assert ET.tostring(link) == ET.tostring(portable_link)
    assert ET.tostring(joint) == ET.tostring(portable_joint)
    assert len(loaded.findall("link")) == len(root.findall("link"))


def test_the_hull_key_is_the_clients() -> None:
    assert HULL == client.HULL
