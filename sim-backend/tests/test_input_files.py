"""Input files are read whole or refused, never cut (issue 34, findings 9 and 11): a joint_limits file, a
launch file or a package.xml above its size limit is refused naming the file, its size and the limit (a
1 MiB cut used to drop the joints past it without a word); YAML nested past the one nesting limit is
refused with its line (it ended in a RecursionError); a joint_limits file naming more joints than the
contract takes says so; and a MoveIt config package is a jail like a twin folder: a `.setup_assistant`
`relative_path` of `../../../etc/passwd` or a file symlinked out of the package is refused with
E_PATH_ESCAPE naming it and who named it."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import BinaryIO

import pytest
from rpc_backend import RpcClient
from simhelp import MODELS

from robwot_sim import scene
from robwot_sim.errors import PathEscape, SceneError, UrdfError
from robwot_sim.jsondepth import MAX_DEPTH
from robwot_sim.limits import MAX_LIMITED_JOINTS
from robwot_sim.model.moveit_config import MAX_LAUNCH_BYTES, find_moveit_config, joint_limits
from robwot_sim.model.ros_packages import MAX_MANIFEST_BYTES, package_name
from robwot_sim.model.yamlsafe import MAX_YAML_BYTES
from robwot_sim.wholefile import TooLarge, atomic_write, read_whole

WS = MODELS / "ros_ws"
CONFIG = WS / "tinyxacro_moveit_config"
DESCRIPTION = WS / "tinyxacro_description"
ROOTS = {"tinyxacro_description": str(DESCRIPTION)}


@pytest.fixture(autouse=True)
def _no_ros_package_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)


@pytest.fixture
def config(tmp_path: Path) -> Path:
    """A copy of the test MoveIt config package, beside nothing else."""
    out = tmp_path / "ws" / "tinyxacro_moveit_config"
    shutil.copytree(CONFIG, out)
    return out


def _limits_past(size: int) -> str:
    """A joint_limits.yaml whose one joint comes after ``size`` bytes of comment lines."""
    line = "# " + "x" * 98 + "\n"
    return line * (size // len(line) + 1) + (
        "joint_limits:\n  yaw:\n    has_velocity_limits: true\n    max_velocity: 0.05\n")


def test_read_whole_takes_a_file_at_its_limit_and_refuses_more_or_an_endless_one(tmp_path: Path) -> None:
    """Exactly the limit is read; one byte more is refused with its size; a device without a size
    (/dev/zero) is refused after reading one byte past the limit, not read without end."""
    f = tmp_path / "f"
    f.write_bytes(b"a" * 100)
    assert read_whole(f, 100) == b"a" * 100
    with pytest.raises(TooLarge) as over:
        read_whole(f, 99)
    assert (over.value.size, over.value.limit) == (100, 99) and "never read in part" in str(over.value)
    with pytest.raises(TooLarge) as endless:
        read_whole("/dev/zero", 1000)
    assert endless.value.limit == 1000 and "more than 1000 bytes" in str(endless.value)


def test_atomic_write_leaves_the_old_file_or_the_new_one_and_nothing_else(tmp_path: Path) -> None:
    """A write that fails halfway leaves the file as it was and no temporary file; one that succeeds
    replaces it whole, readable by others (0644)."""
    f = tmp_path / "f"
    f.write_bytes(b"old")

    def half(out: BinaryIO) -> None:
        out.write(b"new, half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        atomic_write(f, half)
    assert f.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["f"]
    atomic_write(f, lambda out: out.write(b"new"))
    assert f.read_bytes() == b"new" and [p.name for p in tmp_path.iterdir()] == ["f"]
    assert f.stat().st_mode & 0o777 == 0o644


def test_a_limits_file_over_the_yaml_limit_is_refused_not_cut(tmp_path: Path) -> None:
    """The joint past the old 1 MiB cut: refused naming the file, its size and the limit, instead of the
    joint silently keeping its URDF velocity."""
    f = tmp_path / "joint_limits.yaml"
    f.write_text(_limits_past(MAX_YAML_BYTES))
    with pytest.raises(UrdfError) as refused:
        joint_limits(f, required=True)
    size = f.stat().st_size
    assert refused.value.data == {**refused.value.data, "file": str(f), "size": size, "limit": MAX_YAML_BYTES}
    assert f"file of {size} bytes is larger than the limit of {MAX_YAML_BYTES} bytes" in refused.value.message
    f.write_text(_limits_past(1000))  # the same file, small: the joint is read
    assert joint_limits(f).velocities == {"yaw": 0.05}


def test_a_limits_file_over_the_limit_through_the_backend(client: RpcClient, tmp_path: Path) -> None:
    """robot.jointLimits answers E_URDF with the file, its size and the limit; the backend serves on."""
    f = tmp_path / "joint_limits.yaml"
    f.write_text(_limits_past(MAX_YAML_BYTES))
    err = client.error("robot.jointLimits", {"file": str(f)})
    assert err.data["code"] == "E_URDF" and err.data["file"] == str(f)
    assert (err.data["size"], err.data["limit"]) == (f.stat().st_size, MAX_YAML_BYTES)
    assert client.call("ping")["version"]


@pytest.mark.parametrize("nesting", ["[" * 20_000 + "]" * 20_000, "{a: " * 20_000 + "1" + "}" * 20_000])
def test_yaml_nested_past_the_nesting_limit_is_refused_with_its_line(tmp_path: Path, nesting: str) -> None:
    """20,000 levels (a RecursionError before): refused naming the file, the line and the limit; one level
    within the limit still loads."""
    f = tmp_path / "joint_limits.yaml"
    f.write_text("# deep\njoint_limits:\n  yaw: " + nesting + "\n")
    with pytest.raises(UrdfError) as deep:
        joint_limits(f)
    assert deep.value.data["line"] == 3 and deep.value.data["limit"] == MAX_DEPTH
    assert f"deeper than {MAX_DEPTH} levels" in deep.value.message and str(f) in deep.value.message
    f.write_text("joint_limits:\n  yaw: " + "[" * (MAX_DEPTH - 2) + "]" * (MAX_DEPTH - 2) + "\n")
    assert joint_limits(f).velocities == {}


def test_a_limits_file_naming_more_joints_than_the_contract_takes_says_so(client: RpcClient,
                                                                         tmp_path: Path) -> None:
    """19,000 entries: refused naming the file, the count and the limit (it surfaced as "expected an
    object, got object" when the velocities were handed on); a params object past its entry limit is
    described with both counts."""
    f = tmp_path / "joint_limits.yaml"
    f.write_text("joint_limits:\n" + "".join(
        f"  j{k}: {{has_velocity_limits: true, max_velocity: 1}}\n" for k in range(19_000)))
    assert f.stat().st_size < MAX_YAML_BYTES
    err = client.error("robot.jointLimits", {"file": str(f)})
    assert err.data["code"] == "E_URDF" and err.data["file"] == str(f)
    assert (err.data["joints"], err.data["limit"]) == (19_000, MAX_LIMITED_JOINTS)
    assert f"names 19000 joints, more than the {MAX_LIMITED_JOINTS}" in err.error["message"]
    many = {f"j{k}": 1.0 for k in range(MAX_LIMITED_JOINTS + 1)}
    err = client.error("robot.expandXacro", {"xacro": str(DESCRIPTION / "urdf" / "arm.urdf.xacro"),
                                             "velocityLimits": many})
    assert err.data["param"] == "velocityLimits"
    assert err.error["message"].endswith(f"expected an object of at most {MAX_LIMITED_JOINTS} entries, got "
                                         f"object of {MAX_LIMITED_JOINTS + 1} entries")


def test_a_launch_file_or_package_xml_over_its_limit_is_refused_not_cut(config: Path) -> None:
    """A launch file above its limit (its robot_description past the cut) and a package.xml above its
    limit are refused naming the file and the limit, not parsed in part (or skipped as unreadable)."""
    (config / ".setup_assistant").unlink()
    (config / "launch").mkdir()
    launch = config / "launch" / "planning_context.launch"
    launch.write_text("<launch>\n" + "<!-- padding -->\n" * (MAX_LAUNCH_BYTES // 16) +
                      '<param name="robot_description" textfile="$(find tinyxacro_description)/urdf/a.urdf"/>'
                      "\n</launch>\n")
    with pytest.raises(UrdfError) as launched:
        find_moveit_config(config, ROOTS)
    assert launched.value.data["file"] == str(launch) and launched.value.data["limit"] == MAX_LAUNCH_BYTES
    manifest = config / "package.xml"
    manifest.write_text("<package>\n" + "<!-- padding -->\n" * (MAX_MANIFEST_BYTES // 16) +
                        "<name>tinyxacro_moveit_config</name>\n</package>\n")
    with pytest.raises(UrdfError) as named:
        package_name(config)
    assert named.value.data["file"] == str(manifest) and named.value.data["limit"] == MAX_MANIFEST_BYTES


def test_a_scene_file_over_its_limit_is_refused_naming_size_and_limit(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """E_SCENE with the file, its size and the limit."""
    monkeypatch.setattr(scene, "MAX_SCENE_BYTES", 64)
    f = tmp_path / "scene.json"
    f.write_text('{"version": 1, "obstacles": []}' + " " * 64)
    with pytest.raises(SceneError) as refused:
        scene.read_scene(f)
    assert refused.value.data["size"] == f.stat().st_size and refused.value.data["limit"] == 64


@pytest.mark.parametrize("entry", ["URDF", "SRDF"])
def test_setup_assistant_paths_out_of_the_package_are_refused(config: Path, entry: str) -> None:
    """A `relative_path` of ../../../etc/passwd: E_PATH_ESCAPE naming the path, the package folder it
    had to stay in and the `.setup_assistant` entry that named it."""
    assistant = config / ".setup_assistant"
    text = assistant.read_text()
    old = "urdf/arm.urdf.xacro" if entry == "URDF" else "config/tinyxacro.srdf"
    assistant.write_text(text.replace(old, "../../../../../../../../etc/passwd"))
    with pytest.raises(PathEscape) as out:
        find_moveit_config(config, ROOTS)
    assert out.value.data["file"] == "/etc/passwd"
    package = DESCRIPTION if entry == "URDF" else config
    assert out.value.data["roots"] == [str(package)]
    assert f"{entry} relative_path '../../../../../../../../etc/passwd'" in out.value.message
    assert f"must stay inside the package folder {package}" in out.value.message


@pytest.mark.parametrize("name", [".setup_assistant", "config/joint_limits.yaml", "config/tinyxacro.srdf",
                                  "launch/planning_context.launch"])
def test_files_of_the_package_symlinked_out_of_it_are_refused(config: Path, tmp_path: Path,
                                                              name: str) -> None:
    """A config file that is a symbolic link to a file outside the package (here a copy of it, so
    following the link would succeed): refused naming where it leads, before it is read."""
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    link = config / name
    if name.startswith("launch/"):
        (config / ".setup_assistant").unlink()
        link.parent.mkdir()
        target = outside / "planning_context.launch"
        target.write_text('<launch><param name="robot_description" '
                          'textfile="$(find tinyxacro_description)/urdf/arm.urdf.xacro"/></launch>')
    else:
        target = outside / link.name
        shutil.copy(link, target)
        link.unlink()
    os.symlink(target, link)
    with pytest.raises(PathEscape) as out:
        find_moveit_config(config, ROOTS)
    assert out.value.data["file"] == str(target) and out.value.data["roots"] == [str(config)]


def test_a_urdf_symlinked_out_of_its_package_is_refused(tmp_path: Path) -> None:
    """The description package's urdf/ folder linked to a folder outside it: the URDF `.setup_assistant`
    names resolves out of its package and is refused; the unchanged package still reads."""
    ws = tmp_path / "ws"
    shutil.copytree(WS, ws, symlinks=True)
    description = ws / "tinyxacro_description"
    outside = tmp_path / "outside"
    shutil.move(description / "urdf", outside)
    os.symlink(outside, description / "urdf")
    with pytest.raises(PathEscape) as out:
        find_moveit_config(ws / "tinyxacro_moveit_config")
    assert out.value.data["file"] == str(outside / "arm.urdf.xacro")
    assert out.value.data["roots"] == [str(description.resolve())]
    assert find_moveit_config(CONFIG).urdf == DESCRIPTION / "urdf" / "arm.urdf.xacro"
