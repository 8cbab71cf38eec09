"""ROS inputs as they are published: a package without package.xml found by its folder's name (with a
note), and an SRDF with a slip among its names read as MoveIt reads it (the entry skipped, a warning with
file, line and name); an SRDF mostly of another robot's names still refused."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from rpc_backend import BackendProcess
from simhelp import MODELS

from robwot_sim.errors import FileNotFound, PathEscape, SrdfError, UnknownPackage
from robwot_sim.model.ros_packages import MAX_NAMED_LEVELS, folder_named
from robwot_sim.model.srdf import Srdf, disabled_pairs, read_srdf
from robwot_sim.model.urdf import prepare_urdf, resolve_mesh

NOMANIFEST = MODELS / "nomanifest"
ARM_PKG = NOMANIFEST / "tinyarm_description"
ARM = ARM_PKG / "urdf" / "arm.urdf"
ARM_SRDF = ARM_PKG / "srdf" / "arm.srdf"
OTHER_SRDF = NOMANIFEST / "other_robot.srdf"
LINKS = {"base", "upper", "tip"}
JOINTS = {"shoulder", "elbow"}
BASE_MESH = "package://tinyarm_description/meshes/base.obj"


@pytest.fixture(autouse=True)
def _no_ros_package_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)


def _package(where: Path, declared: str | None) -> Path:
    """A package folder ``where`` holding meshes/base.obj, with a package.xml naming ``declared``."""
    (where / "meshes").mkdir(parents=True)
    shutil.copy(ARM_PKG / "meshes" / "base.obj", where / "meshes")
    if declared is not None:
        (where / "package.xml").write_text(f"<package format='2'><name>{declared}</name></package>")
    return where


def test_package_taken_by_the_folder_holding_the_urdf_with_a_note() -> None:
    """No package.xml names tinyarm_description: the folder of that name holding the URDF is the package,
    and a note names the URDF, the line, the folder and the option that chooses another."""
    notes: dict[str, str] = {}
    got = resolve_mesh(BASE_MESH, ARM.parent, urdf=str(ARM), line=6, notes=notes)
    assert got == ARM_PKG / "meshes" / "base.obj"
    assert list(notes) == ["tinyarm_description"]
    assert notes["tinyarm_description"].startswith(f"{ARM}:6: {BASE_MESH}: no package.xml names ROS package")
    assert f"taken as the folder {ARM_PKG} by its name" in notes["tinyarm_description"]
    assert "--package-root tinyarm_description=DIR" in notes["tinyarm_description"]


def test_package_taken_by_a_folder_beside_one_holding_the_urdf() -> None:
    """tinyarm_meshes stands beside tinyarm_description: found there; prepare_urdf keeps one note per
    package, whatever the number of meshes in it."""
    tip = NOMANIFEST / "tinyarm_meshes" / "tip.obj"
    assert resolve_mesh("package://tinyarm_meshes/tip.obj", ARM.parent) == tip
    prepared = prepare_urdf(ARM)
    try:
        assert len(prepared.notes) == 2
        assert [n.split("package://")[1].split("/")[0] for n in prepared.notes] == [
            "tinyarm_description", "tinyarm_meshes"]
        assert prepared.meshes["package://tinyarm_meshes/tip.obj"] == tip
    finally:
        prepared.cleanup()


def test_package_xml_and_package_roots_win_over_a_folder_name(tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """A package.xml naming the package (on ROS_PACKAGE_PATH) and --package-root come first: no folder is
    taken by its name then, and no note is made."""
    declared = _package(tmp_path / "path" / "real_one", "tinyarm_description")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(tmp_path / "path"))
    notes: dict[str, str] = {}
    assert resolve_mesh(BASE_MESH, ARM.parent, notes=notes) == (declared / "meshes" / "base.obj").resolve()
    assert notes == {}
    monkeypatch.delenv("ROS_PACKAGE_PATH")
    chosen = _package(tmp_path / "chosen", None)
    got = resolve_mesh(BASE_MESH, ARM.parent, {"tinyarm_description": str(chosen)}, notes=notes)
    assert got == (chosen / "meshes" / "base.obj").resolve() and notes == {}


def test_a_folder_whose_package_xml_names_another_package_is_not_taken(tmp_path: Path) -> None:
    """arm_description/package.xml says <name>other</name>: that folder is not the package
    arm_description, which is then found nowhere (UnknownPackage with file and line)."""
    pkg = _package(tmp_path / "ws" / "arm_description", "other")
    (pkg / "urdf").mkdir()
    with pytest.raises(UnknownPackage) as ei:
        resolve_mesh("package://arm_description/meshes/base.obj", pkg / "urdf", urdf="a.urdf", line=3)
    assert ei.value.data["line"] == 3 and ei.value.data["package"] == "arm_description"
    assert ei.value.message.startswith("a.urdf:3: package://arm_description/meshes/base.obj: ROS package")


def test_folder_names_stay_near_the_file_and_off_general_folders(tmp_path: Path) -> None:
    """Only within MAX_NAMED_LEVELS of the file's folder; never the filesystem root's children (/tmp) or
    the home folder, which merely have a name."""
    deep = tmp_path / "far_description" / Path(*"abcdefgh"[: MAX_NAMED_LEVELS + 1])
    deep.mkdir(parents=True)
    assert folder_named(deep.parent, "far_description") == tmp_path / "far_description"
    assert folder_named(deep, "far_description") is None
    assert folder_named(Path("/tmp/robwot-nowhere/urdf"), "tmp") is None
    home = Path.home().resolve()
    assert folder_named(home / "robot" / "urdf", home.name) is None
    assert folder_named(tmp_path, "..") is None and folder_named(tmp_path, "") is None


def test_a_folder_taken_by_its_name_is_a_jail(tmp_path: Path) -> None:
    """`..` out of the folder, and a sibling or mesh that is a symlink leading elsewhere, are refused: no
    file outside the folders a package may be is ever returned."""
    ws = tmp_path / "ws"
    (ws / "arm_description" / "urdf").mkdir(parents=True)
    udir = ws / "arm_description" / "urdf"
    shutil.copy(ARM_PKG / "meshes" / "base.obj", ws / "secret.obj")
    with pytest.raises((PathEscape, FileNotFound)) as ei:
        resolve_mesh("package://arm_description/../secret.obj", udir)
    assert str(ws / "secret.obj") not in str(ei.value.data)
    outside = _package(tmp_path / "outside", None)
    os.symlink(outside, ws / "arm_meshes")
    with pytest.raises(PathEscape):
        resolve_mesh("package://arm_meshes/meshes/base.obj", udir)
    (ws / "arm_description" / "meshes").mkdir()
    os.symlink(ws / "secret.obj", ws / "arm_description" / "meshes" / "link.obj")
    with pytest.raises(PathEscape):
        resolve_mesh("package://arm_description/meshes/link.obj", udir)


def test_srdf_entry_of_an_unknown_link_skipped_with_a_warning() -> None:
    """The chain naming base_link (the URDF says base) is skipped with a warning naming the file, line 8
    and the name; the groups' joints, the other chain, the state, the end effector and the pairs stay."""
    s = read_srdf(ARM_SRDF, LINKS, JOINTS)
    assert s.warnings == [f"{ARM_SRDF}:8: link 'base_link' is not a link of the robot: the chain "
                          "base_link -> tip of group 'arm' skipped, as MoveIt does"]
    assert s.groups["arm"].joints == ["shoulder", "elbow"] and s.groups["arm"].chains == []
    assert s.groups["whole"].chains == [("base", "tip")]
    assert s.group_states == {"arm": {"home": {"shoulder": 0.5, "elbow": -1.0}}}
    assert s.end_effectors == [("hand", "tip", "whole", "arm")]
    assert s.disabled == {("base", "upper"), ("tip", "upper")}
    assert s.to_json()["warnings"] == s.warnings
    assert disabled_pairs(ARM_SRDF, LINKS) == s.disabled


@pytest.mark.parametrize(("element", "kept"), [
    ('<group_state name="s" group="g"><joint name="knee" value="x"/><joint name="yaw" value="1"/>'
     '</group_state>', lambda s: s.group_states == {"g": {"s": {"yaw": 1.0}}}),
    ('<end_effector name="e" parent_link="hand" group="g"/>', lambda s: s.end_effectors == []),
    ('<disable_collisions link1="base" link2="hand" reason="Never"/>', lambda s: s.disabled == frozenset()),
    ('<passive_joint name="knee"/>', lambda s: True),
])
def test_each_kind_of_entry_skipped_alone(tmp_path: Path, element: str, kept: Callable[[Srdf], bool]) -> None:
    """A state's joint value, an end effector, a disabled pair, a passive joint naming what the robot lacks:
    that entry alone is skipped and warned about (line 3); the known names around it are kept."""
    p = tmp_path / "r.srdf"
    p.write_text('<?xml version="1.0"?>\n<robot name="r">\n<group name="g"><joint name="yaw"/><joint '
                 f'name="pitch"/><link name="base"/></group>{element}\n</robot>\n')
    s = read_srdf(p, {"base", "arm"}, {"yaw", "pitch"})
    assert len(s.warnings) == 1 and s.warnings[0].startswith(f"{p}:3: ")
    assert kept(s)


def test_srdf_mostly_of_unknown_names_refused_as_another_robots() -> None:
    """other_robot.srdf names five links and joints tinyarm lacks and one it has: refused (E_SRDF) at the
    line of its first unknown name, saying how many are unknown; half unknown is still accepted."""
    with pytest.raises(SrdfError) as ei:
        read_srdf(OTHER_SRDF, LINKS, JOINTS)
    e = ei.value
    assert e.code == "E_SRDF" and e.data["file"] == str(OTHER_SRDF) and e.data["line"] == 5
    assert (e.data["name"], e.data["unknown"], e.data["names"]) == ("panda_link0", 5, 6)
    assert "5 of the 6 links and joints the SRDF names are not the robot's: is this the SRDF of another " \
        "robot?" in e.message
    with pytest.raises(SrdfError):
        disabled_pairs(OTHER_SRDF, LINKS)


def test_half_unknown_is_not_most(tmp_path: Path) -> None:
    """One known link and one unknown in the only entry: warned and skipped, not refused."""
    p = tmp_path / "half.srdf"
    p.write_text('<robot name="r">\n<disable_collisions link1="base" link2="gone" reason="x"/>\n</robot>')
    s = read_srdf(p, LINKS, JOINTS)
    assert s.disabled == frozenset() and len(s.warnings) == 1 and "'gone'" in s.warnings[0]


def test_load_reports_the_package_notes_and_srdf_warnings(backend: BackendProcess) -> None:
    """robot.load over the wire (its result checked against the contract): the two packages taken by
    their folder's name and the SRDF's skipped chain are in `warnings`; the SRDF's pairs are filtered."""
    c = backend.client()
    try:
        c.call("world.reset")
        model = c.call("robot.load", {"urdf": str(ARM), "id": "tinyarm", "srdf": str(ARM_SRDF)})
        assert len(model["warnings"]) == 3
        assert "tinyarm_description" in model["warnings"][0] and "tinyarm_meshes" in model["warnings"][1]
        assert model["warnings"][2].startswith(f"{ARM_SRDF}:8: link 'base_link'")
        pairs = {tuple(sorted(p)) for p in model["filteredPairs"]}
        assert {("base", "upper"), ("tip", "upper")} <= pairs
        assert "warnings" not in c.call("robot.model", {"robot": "tinyarm"})
        info = c.call("robot.readSrdf", {"srdf": str(ARM_SRDF), "urdf": str(ARM)})
        assert info["warnings"] == model["warnings"][2:]
    finally:
        c.close()
