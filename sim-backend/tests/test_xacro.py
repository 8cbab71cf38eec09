"""xacro files expanded with the xacro package, unexpanded xacro refused in a URDF, and package:// found on
ROS_PACKAGE_PATH or refused naming the option that fixes it."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
from simhelp import MODELS

from robwot_sim.errors import FileNotFound, Forbidden, PathEscape, SimError, UnknownPackage, UrdfError
from robwot_sim.model.urdf import read_urdf, resolve_mesh
from robwot_sim.model.xacro_expand import SOURCE_ROOT, expand_xacro
from robwot_sim.sim.world import World

WS = MODELS / "ros_ws"
ARM = WS / "tinyxacro_description" / "urdf" / "arm.urdf.xacro"
TOOL_PKG = WS / "extra" / "tool_pkg_folder"
NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def _expanded(xacro: Path, args: dict[str, str] | None = None,
              roots: dict[str, str] | None = None) -> tuple[Path, dict[str, str]]:
    urdf, package_roots = expand_xacro(xacro, args, roots)
    assert urdf.parent.name.startswith("robwot-xacro-")
    return urdf, package_roots


@pytest.fixture(autouse=True)
def _no_ros_package_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)


def _write(folder: Path, name: str, text: str) -> Path:
    p = folder / name
    p.write_text(text)
    return p


def test_property_macro_arg_and_find_expand_into_a_loadable_urdf() -> None:
    """A property, a macro, an include through $(find), an arg and package:// meshes become a URDF that
    loads with the returned package roots; the arg changes the kinematics."""
    for length, tip_z in (("0.3", 0.65), ("0.25", 0.6)):
        urdf, roots = _expanded(ARM, {"upper_length": length})
        try:
            assert roots["tinyxacro_description"] == str(WS / "tinyxacro_description")
            assert roots[SOURCE_ROOT] == str(ARM.parent)
            root = read_urdf(urdf)
            assert {el.get("name") for el in root.iter("link")} == {"base", "turret", "upper", "fore", "tip"}
            box = root.find("link[@name='upper']/collision/geometry/box")
            assert box is not None and box.get("size") == f"0.04 0.04 {length}"
            with World() as w:
                model = w.load_robot(urdf, package_roots=roots)
                assert list(model.controllable) == ["yaw", "shoulder", "elbow"]
                pose = w.fk(model.id, np.zeros(3))
                assert pose.position == pytest.approx([0, 0, tip_z], abs=1e-6)
        finally:
            shutil.rmtree(urdf.parent)


def test_package_on_ros_package_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """package://NAME is found on ROS_PACKAGE_PATH by its package.xml <name>, not by its folder's name;
    without it the error names the package and both ways to give it."""
    with pytest.raises(UnknownPackage) as ei:
        expand_xacro(ARM, {"with_tool": "true"})
    msg = ei.value.message
    assert ei.value.code == "E_FILE_NOT_FOUND" and str(ARM) in msg
    assert "package://tinytool/meshes/tool.stl" in msg and "ROS package 'tinytool' not found" in msg
    assert "--package-root tinytool=DIR" in msg and "ROS_PACKAGE_PATH" in msg
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"/nonexistent:{WS / 'extra'}")
    urdf, roots = _expanded(ARM, {"with_tool": "true"})
    try:
        assert roots["tinytool"] == str(TOOL_PKG)
        with World() as w:
            assert "tool" in w.load_robot(urdf, package_roots=roots).links
    finally:
        shutil.rmtree(urdf.parent)


def test_plain_urdf_package_resolution_and_hint(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A plain URDF's package:// mesh: refused naming the file, line, package and the option; found on
    ROS_PACKAGE_PATH; a folder merely named like the package (no package.xml) is not a package."""
    urdf = _write(tmp_path, "r.urdf", '<robot name="r">\n<link name="a">\n<collision><geometry>\n'
                  '<mesh filename="package://tinytool/meshes/tool.stl"/></geometry></collision></link>\n'
                  '<link name="b"/><joint name="j" type="continuous"><parent link="a"/><child link="b"/>'
                  '</joint></robot>')
    with pytest.raises(UnknownPackage) as ei:
        resolve_mesh("package://tinytool/meshes/tool.stl", tmp_path, urdf=str(urdf), line=4)
    assert ei.value.message.startswith(
        f"{urdf}:4: package://tinytool/meshes/tool.stl: ROS package 'tinytool'")
    assert "give --package-root tinytool=DIR" in ei.value.message
    with World() as w, pytest.raises(UnknownPackage) as load:
        w.load_robot(urdf)
    assert load.value.data["line"] == 4 and load.value.data["package"] == "tinytool"
    fake = tmp_path / "path" / "tinytool" / "meshes"
    fake.mkdir(parents=True)
    shutil.copy(TOOL_PKG / "meshes" / "tool.stl", fake)
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "path"))
    with pytest.raises(UnknownPackage):  # named tinytool, but no package.xml says so
        resolve_mesh("package://tinytool/meshes/tool.stl", tmp_path)
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"{tmp_path / 'path'}:{WS}")
    assert resolve_mesh("package://tinytool/meshes/tool.stl", tmp_path) == TOOL_PKG / "meshes" / "tool.stl"
    # a package found but the file missing inside it: not an unknown package
    with pytest.raises(FileNotFound) as missing:
        resolve_mesh("package://tinytool/meshes/nope.stl", tmp_path)
    assert not isinstance(missing.value, UnknownPackage)
    assert str(TOOL_PKG / "meshes" / "nope.stl") in missing.value.message


@pytest.mark.parametrize(("name", "urdf_line", "says"), [
    ("xacro_as_urdf.urdf", 10, "unexpanded xacro '0 0 ${L}' in attribute 'xyz' of <origin>"),
    ("xacro_in_collision.urdf", 7,
     "unexpanded xacro '0.1 0.1 $(arg arm_length)' in attribute 'size' of <box>"),
])
def test_unexpanded_xacro_in_a_urdf_refused_with_line(name: str, urdf_line: int, says: str) -> None:
    """${...} or $(...) left in a URDF (collision geometry included): refused with file:line and the hint."""
    with pytest.raises(UrdfError) as ei:
        read_urdf(MODELS / name)
    assert ei.value.data["line"] == urdf_line
    assert ei.value.message.startswith(f"{MODELS / name}:{urdf_line}: {says}")
    assert "a xacro file? name it .xacro or pass it as robot.urdf.xacro" in ei.value.message


def test_unexpanded_text_refused_and_comments_ignored(tmp_path: Path) -> None:
    """Element text is checked too; a comment may hold anything."""
    p = _write(tmp_path, "t.urdf", '<robot name="t">\n<!-- ${not read} -->\n<link name="a"/>\n'
               '<gazebo>\n<ns>$(arg ns)</ns></gazebo></robot>')
    with pytest.raises(UrdfError) as ei:
        read_urdf(p)
    assert ei.value.data["line"] == 5 and "in the text of <ns>" in ei.value.message
    p.write_text('<robot name="t">\n<!-- ${not read} $(arg x) -->\n<link name="a"/></robot>')
    assert read_urdf(p).tag == "robot"


@pytest.mark.parametrize(("text", "line", "says"), [
    ('<robot name="b" xmlns:xacro="http://www.ros.org/wiki/xacro">\n<link name="a"/>\n'
     '<link name="c"><collision><geometry><box size="${W} 1 1"/></geometry></collision></link>\n</robot>',
     3, "xacro: name 'W' is not defined"),
    (f'<robot name="b" {NS}>\n<link name="a">\n<link name="c"/>\n</robot>',
     4, "xacro: not well-formed XML: mismatched tag"),
    (f'<robot name="b" {NS}>\n\n<link name="$(arg prefix)a"/>\n</robot>',
     3, "xacro: undefined argument 'prefix': give it with --xacro-arg prefix:=VALUE"),
])
def test_xacro_errors_name_file_and_line(tmp_path: Path, text: str, line: int, says: str) -> None:
    """xacro's own errors become E_URDF naming the xacro file and the line."""
    p = _write(tmp_path, "b.urdf.xacro", text)
    with pytest.raises(UrdfError) as ei:
        expand_xacro(p)
    assert ei.value.data["file"] == str(p) and ei.value.data["line"] == line
    assert ei.value.message.startswith(f"{p}:{line}") and says in ei.value.message


def test_xacro_reads_only_inside_its_roots_and_no_dtd(tmp_path: Path) -> None:
    """An include outside the xacro's folder/package/roots is refused, a DOCTYPE too (with its line), and
    $(find) of an unknown package names the option."""
    (tmp_path / "in").mkdir()
    _write(tmp_path, "outside.xacro", '<robot xmlns:xacro="http://www.ros.org/wiki/xacro"/>')
    inc = _write(tmp_path / "in", "inc.urdf.xacro", '<robot name="i" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                 '<xacro:include filename="../outside.xacro"/><link name="a"/></robot>')
    with pytest.raises(PathEscape) as esc:
        expand_xacro(inc)
    assert str(tmp_path / "outside.xacro") in esc.value.message and esc.value.code == "E_PATH_ESCAPE"
    dtd = _write(tmp_path / "in", "dtd.urdf.xacro", '<?xml version="1.0"?>\n<!DOCTYPE r [<!ENTITY a "b">]>\n'
                 '<robot name="&a;"/>')
    with pytest.raises(Forbidden) as forb:
        expand_xacro(dtd)
    assert forb.value.message.startswith(f"{dtd}:2: XML DOCTYPE declarations are refused")
    find = _write(tmp_path / "in", "find.urdf.xacro", '<robot name="f" xmlns:xacro="http://www.ros.org/wiki/xacro">'
                  '<xacro:include filename="$(find nosuch_pkg)/x.xacro"/></robot>')
    with pytest.raises(SimError) as nf:
        expand_xacro(find)
    assert nf.value.code == "E_FILE_NOT_FOUND"
    assert "$(find nosuch_pkg): ROS package 'nosuch_pkg' not found" in nf.value.message
    assert "--package-root nosuch_pkg=DIR" in nf.value.message


def test_xacro_sees_no_robwot_environment(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """$(optenv ...) reads the environment without the backend's ROBWOT_* variables (a token must not
    reach a robot.urdf); other variables stay (ROS users set their robot with them)."""
    monkeypatch.setenv("ROBWOT_BACKEND_TOKEN", "s3cret")
    monkeypatch.setenv("ARM_NAME", "from_env")
    p = _write(tmp_path, "e.urdf.xacro", '<robot name="$(optenv ARM_NAME x)" '
               f'{NS}><link name="t_$(optenv ROBWOT_BACKEND_TOKEN none)"/></robot>')
    urdf, _ = _expanded(p)
    try:
        root = read_urdf(urdf)
        assert root.get("name") == "from_env"
        assert [el.get("name") for el in root.iter("link")] == ["t_none"]
    finally:
        shutil.rmtree(urdf.parent)


def test_relative_mesh_of_a_xacro_outside_any_package(tmp_path: Path) -> None:
    """A mesh path relative to the xacro's folder still resolves from the expanded file's own folder."""
    (tmp_path / "meshes").mkdir()
    shutil.copy(TOOL_PKG / "meshes" / "tool.stl", tmp_path / "meshes" / "m.stl")
    p = _write(tmp_path, "rel.xacro", f'<robot name="rel" {NS}><link name="a"/><link name="b">'
               '<collision><geometry><mesh filename="meshes/m.stl"/></geometry></collision>'
               '<inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" '
               'izz="0.01"/></inertial></link><joint name="j" type="revolute">'
               '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
               '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>')
    urdf, roots = _expanded(p)
    try:
        assert urdf.name == "rel.urdf"
        with World() as w:
            assert list(w.load_robot(urdf, package_roots=roots).controllable) == ["j"]
    finally:
        shutil.rmtree(urdf.parent)


def test_package_in_an_ament_prefix(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """ROS 2: package://NAME is PREFIX/share/NAME of an AMENT_PREFIX_PATH install prefix (its package.xml
    names it); a share folder of that name whose package.xml names another package is not it."""
    from robwot_sim.model.ros_packages import find_on_ros_package_path

    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    impostor = tmp_path / "first" / "share" / "tinytool"
    impostor.mkdir(parents=True)
    (impostor / "package.xml").write_text("<package><name>other</name></package>")
    installed = tmp_path / "install" / "share" / "tinytool"
    shutil.copytree(TOOL_PKG, installed)
    monkeypatch.setenv("AMENT_PREFIX_PATH", f"{tmp_path / 'first'}:{tmp_path / 'install'}")
    assert find_on_ros_package_path("tinytool") == installed.resolve()
    urdf, roots = _expanded(ARM, {"with_tool": "true"})
    try:
        assert roots["tinytool"] == str(installed.resolve())
    finally:
        shutil.rmtree(urdf.parent)
