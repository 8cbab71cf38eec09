"""Safe URDF reading and mesh resolution: every refusal names the file (H1)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from simhelp import DATA, MODELS, PANDA, XARM

from robwot_sim.errors import FileNotFound, Forbidden, MeshError, NoMovableJoint, PathEscape, UrdfError
from robwot_sim.model.urdf import read_urdf, resolve_mesh
from robwot_sim.sim.world import World


def test_doctype_and_entities_refused_before_parsing() -> None:
    """A DOCTYPE with entities (billion laughs, XXE) is Forbidden with the line, never expanded."""
    with pytest.raises(Forbidden) as ei:
        read_urdf(MODELS / "doctype.urdf")
    assert ei.value.code == "E_FORBIDDEN" and ei.value.data["line"] == 2
    assert ei.value.data["file"].endswith("doctype.urdf")


def test_entity_in_utf16_document_refused(tmp_path) -> None:
    """The byte scan cannot see UTF-16 text; the parser refuses the DTD there too."""
    p = tmp_path / "x.urdf"
    p.write_bytes(
        '<?xml version="1.0" encoding="UTF-16"?>\n<!DOCTYPE r [<!ENTITY a "b">]>\n<robot name="&a;"/>'.encode(
            "utf-16"
        )
    )
    with pytest.raises(Forbidden):
        read_urdf(p)


def test_malformed_xml_names_line_and_column() -> None:
    """An XML error is UrdfError with file, line and column."""
    with pytest.raises(UrdfError) as ei:
        read_urdf(MODELS / "malformed.urdf")
    assert (ei.value.data["line"], ei.value.data["column"]) == (8, 5)
    assert ei.value.rpc_code == -32003


def test_structural_errors(tmp_path) -> None:
    """No movable joint, a revolute joint without limits and a wrong root are UrdfErrors."""
    with World() as w:
        with pytest.raises(NoMovableJoint) as ei:
            w.load_robot(MODELS / "no_movable.urdf")
        assert ei.value.code == "E_NO_MOVABLE_JOINT"
        p = tmp_path / "nolimit.urdf"
        p.write_text(
            '<robot name="n"><link name="a"/><link name="b"/>\n<joint name="j" type="revolute">'
            '<parent link="a"/><child link="b"/></joint></robot>'
        )
        with pytest.raises(UrdfError) as lim:
            w.load_robot(p)
        assert lim.value.data["line"] == 2 and lim.value.data["joint"] == "j"
        p.write_text("<model/>")
        with pytest.raises(UrdfError):
            w.load_robot(p)
        with pytest.raises(FileNotFound):
            w.load_robot(tmp_path / "absent.urdf")
        assert w.list()["robots"] == []


def test_missing_mesh_names_the_file() -> None:
    """A missing mesh is FileNotFound naming the mesh and the URDF."""
    with World() as w, pytest.raises(FileNotFound) as ei:
        w.load_robot(MODELS / "bad_mesh.urdf")
    assert ei.value.data["file"].endswith("meshes/missing_part.stl")
    assert ei.value.data["urdf"].endswith("bad_mesh.urdf")


@pytest.mark.parametrize("name", ["escape.urdf", "escape_relative.urdf"])
def test_mesh_paths_escaping_roots_refused(name: str) -> None:
    """Absolute or ../ mesh paths outside the URDF folder, package roots and pybullet_data are refused."""
    with World() as w, pytest.raises(PathEscape) as ei:
        w.load_robot(MODELS / name)
    assert ei.value.code == "E_PATH_ESCAPE" and ei.value.rpc_code == -32005
    assert str(MODELS) in ei.value.data["roots"]


def test_symlink_out_of_root_refused(tmp_path) -> None:
    """A mesh that is a symlink to a file outside the roots is refused too."""
    (tmp_path / "robot").mkdir()
    os.symlink("/etc/hostname", tmp_path / "robot" / "link.stl")
    with pytest.raises(PathEscape):
        resolve_mesh("link.stl", tmp_path / "robot", None)


def test_package_uris_never_name_the_filesystem_root_or_a_mere_folder(tmp_path: Path) -> None:
    """An empty package name, a folder named like the package whose package.xml names another, and `..`
    out of a package root are refused: no file outside the allowed roots is reachable. (A folder with the
    name and no package.xml is taken, near the URDF only: test_friendly_ros_inputs.py.)"""
    (tmp_path / "tmp" / "robot").mkdir(parents=True)
    (tmp_path / "tmp" / "secret.stl").write_bytes(b"x")
    udir = tmp_path / "tmp" / "robot"
    for bad in ("package:///etc/hostname", f"package:///{tmp_path}/tmp/secret.stl", "package://../tmp/secret.stl"):
        with pytest.raises(PathEscape):
            resolve_mesh(bad, udir)
    # a folder named like the package but declaring another is searched only inside the allowed roots,
    # never as a root itself
    (tmp_path / "tmp" / "package.xml").write_text("<package><name>other</name></package>")
    with pytest.raises(FileNotFound) as ei:
        resolve_mesh("package://tmp/secret.stl", udir)
    assert str(tmp_path / "tmp" / "secret.stl") not in ei.value.data["searched"]
    (tmp_path / "shared").mkdir()
    with pytest.raises((PathEscape, FileNotFound)):  # `..` may only lead to places inside the roots
        resolve_mesh("package://shared/../tmp/secret.stl", udir, {"shared": str(tmp_path / "shared")})


def test_package_uris_resolved() -> None:
    """package:// resolves via user roots, the ROS package holding the URDF (package.xml), a folder of the
    package's name beside the URDF's package and pybullet_data layouts."""
    udir = MODELS / "pkgtest" / "urdf"
    assert (
        resolve_mesh("package://pkgtest/meshes/cube.stl", udir) == MODELS / "pkgtest" / "meshes" / "cube.stl"
    )
    assert (
        resolve_mesh("package://shared/cube.obj", udir, {"shared": str(MODELS / "shared")})
        == MODELS / "shared" / "cube.obj"
    )
    assert resolve_mesh("package://meshes/collision/link0.obj", (DATA / PANDA).parent).is_file()
    assert resolve_mesh(
        "package://xarm_description/meshes/xarm6/visual/base.stl", (DATA / XARM).parent
    ).is_file()
    # no package.xml names "shared": the folder of that name beside pkgtest/ is taken, and a note says so
    notes: dict[str, str] = {}
    assert resolve_mesh("package://shared/cube.obj", udir, notes=notes) == MODELS / "shared" / "cube.obj"
    assert list(notes) == ["shared"]
    with pytest.raises(FileNotFound) as ei:
        resolve_mesh("package://nowhere/cube.obj", udir)
    assert ei.value.data["reference"] == "package://nowhere/cube.obj"


def test_stl_obj_dae_meshes_load_as_collision_shapes() -> None:
    """ASCII STL (converted), OBJ and DAE collision meshes all become collision shapes in PyBullet."""
    with World() as w:
        m = w.load_robot(MODELS / "mesh_formats.urdf")
        e = w.scene.entry(m.id)
        for link in ("base", "a", "b"):
            assert w.scene.bullet.has_collision_shape(e.bound.body, e.bound.link_index[link])
        w.set_joint_positions(m.id, [0.0, 0.0])
        w.add_obstacle(
            {"name": "probe", "shape": {"type": "sphere", "radius": 0.03}, "position": [0.6, 0.0, 0.4]}
        )
        rep = w.check_collision(m.id)
        assert any(c.a.link == "b" and c.b.body == "probe" for c in rep.contacts)


def test_unreadable_mesh_is_an_error(tmp_path) -> None:
    """A mesh PyBullet would silently drop (garbage OBJ) is refused by our parser, naming URDF and line."""
    (tmp_path / "bad.obj").write_text("this is not an obj file\n")
    (tmp_path / "r.urdf").write_text(
        (MODELS / "mesh_formats.urdf").read_text().replace("meshes/cube.obj", "bad.obj")
    )
    (tmp_path / "meshes").mkdir()
    for f in ("cube.stl", "cube.dae"):
        (tmp_path / "meshes" / f).write_bytes((MODELS / "meshes" / f).read_bytes())
    with World() as w:
        with pytest.raises(MeshError) as ei:
            w.load_robot(tmp_path / "r.urdf")
        assert "bad.obj" in ei.value.message and ei.value.data["reason"] == "OBJ without any face"
        assert ei.value.data["urdf"] == str((tmp_path / "r.urdf").resolve()) and ei.value.data["line"]
        assert w.list()["robots"] == []


@pytest.mark.parametrize(("limit", "reason"), [
    ('lower="-1e308" upper="1e308" velocity="1"', "beyond"),
    ('lower="-1" upper="1" velocity="1e-300"', "velocity limit"),
    ('lower="-1" upper="1" velocity="1e300"', "velocity limit"),
    ('lower="-1e400" upper="1" velocity="1"', "not finite"),
])
def test_absurd_joint_limits_are_refused_naming_the_joint(tmp_path: Path, limit: str, reason: str) -> None:
    """Limits that would overflow the planner (+-1e308, velocities of 1e-300 or 1e300) are refused at load
    with the file, line and joint."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text(f"""<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
<limit {limit} effort="1"/></joint></robot>""")
    with World() as w, pytest.raises(UrdfError) as ei:
        w.load_robot(urdf)
    assert reason in ei.value.message and ei.value.data["line"] == 3
    assert ei.value.data.get("joint", "j") == "j"
