"""A MoveIt config package read as the robot it describes, and an SRDF's every name checked against the
URDF (an SRDF for another robot refused with file and line; one slip skipped: test_friendly_ros_inputs.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from simhelp import MODELS

from robwot_sim.errors import FileNotFound, SrdfError, UrdfError
from robwot_sim.model.moveit_config import find_moveit_config
from robwot_sim.model.srdf import read_srdf
from robwot_sim.model.xacro_expand import expand_xacro

WS = MODELS / "ros_ws"
CONFIG = WS / "tinyxacro_moveit_config"
DESCRIPTION = WS / "tinyxacro_description"
LINKS = {"base", "turret", "upper", "fore", "tip"}
JOINTS = {"yaw", "shoulder", "elbow", "wrist"}


@pytest.fixture(autouse=True)
def _no_ros_package_path(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)


def test_setup_assistant_names_urdf_args_srdf_and_limits() -> None:
    """.setup_assistant gives the description package (found as a sibling folder), its xacro and args,
    the SRDF; joint_limits.yaml the velocities and accelerations of joints that have them."""
    c = find_moveit_config(CONFIG)
    assert c.urdf == DESCRIPTION / "urdf" / "arm.urdf.xacro"
    assert c.xacro_args == {"upper_length": "0.25"}
    assert c.srdf == CONFIG / "config" / "tinyxacro.srdf"
    assert c.package_roots == {"tinyxacro_moveit_config": str(CONFIG),
                               "tinyxacro_description": str(DESCRIPTION)}
    assert c.limits.velocities == {"yaw": 0.5, "elbow": 0.75}
    assert c.limits.accelerations == {"elbow": 2.0}
    assert c.to_json()["accelerationLimits"] == {"elbow": 2.0}


def test_config_folder_without_setup_assistant(tmp_path: Path) -> None:
    """Without .setup_assistant: the one config/*.urdf.xacro and config/*.srdf; two candidates or none
    are refused naming the folder."""
    cfg = tmp_path / "arm_moveit_config" / "config"
    cfg.mkdir(parents=True)
    with pytest.raises(FileNotFound) as none:
        find_moveit_config(cfg.parent)
    assert "no .setup_assistant, no config/*.urdf.xacro|*.xacro|*.urdf, no robot_description in launch" \
        in none.value.message
    shutil.copy(DESCRIPTION / "urdf" / "arm.urdf.xacro", cfg / "arm.urdf.xacro")
    shutil.copy(CONFIG / "config" / "tinyxacro.srdf", cfg / "arm.srdf")
    c = find_moveit_config(cfg.parent)
    assert (c.urdf, c.srdf) == (cfg / "arm.urdf.xacro", cfg / "arm.srdf")
    assert (c.xacro_args, c.limits.velocities, c.limits.accelerations) == ({}, {}, {})
    shutil.copy(cfg / "arm.srdf", cfg / "other.srdf")
    with pytest.raises(UrdfError) as two:
        find_moveit_config(cfg.parent)
    assert "several SRDF files (arm.srdf, other.srdf)" in two.value.message


def test_bad_joint_limits_and_unknown_description_package(tmp_path: Path) -> None:
    """joint_limits.yaml that is not YAML (with its line) or gives a velocity <= 0 is refused; a
    .setup_assistant package found nowhere names the option."""
    cfg = tmp_path / "c"
    shutil.copytree(CONFIG, cfg)
    (cfg / "config" / "joint_limits.yaml").write_text("joint_limits:\n  yaw:\n    max_velocity: [1\n")
    with pytest.raises(UrdfError) as bad:
        find_moveit_config(cfg, {"tinyxacro_description": str(DESCRIPTION)})
    assert bad.value.data["file"].endswith("joint_limits.yaml") and bad.value.data["line"] == 4
    (cfg / "config" / "joint_limits.yaml").write_text(
        "joint_limits:\n  yaw:\n    has_velocity_limits: true\n    max_velocity: 0\n")
    with pytest.raises(UrdfError) as zero:
        find_moveit_config(cfg, {"tinyxacro_description": str(DESCRIPTION)})
    assert "joint 'yaw': max_velocity 0 must be a positive number" in zero.value.message
    (cfg / "config" / "joint_limits.yaml").unlink()
    with pytest.raises(FileNotFound) as pkg:  # tmp_path holds no sibling description package
        find_moveit_config(cfg)
    assert "--package-root tinyxacro_description=DIR" in pkg.value.message


def test_velocity_limit_of_an_unknown_joint_refused() -> None:
    """A joint_limits.yaml joint the robot lacks is refused naming it and the robot's joints."""
    with pytest.raises(UrdfError) as ei:
        expand_xacro(DESCRIPTION / "urdf" / "arm.urdf.xacro", {}, {}, {"knee": 1.0})
    assert "joint_limits.yaml names joint 'knee', which the robot does not have" in ei.value.message


def test_srdf_read_with_groups_states_and_end_effectors() -> None:
    """Groups (chains, links), the home state and end effectors in file order."""
    s = read_srdf(CONFIG / "config" / "tinyxacro.srdf", LINKS, JOINTS)
    assert list(s.groups) == ["arm", "to_elbow", "hand"]
    assert s.groups["arm"].chains == [("base", "tip")]
    assert s.group_states == {"arm": {"home": {"yaw": 0.0, "shoulder": 0.5, "elbow": -1.0}}}
    assert [e[:2] for e in s.end_effectors] == [("elbow_tool", "fore"), ("gripper", "tip")]


@pytest.mark.parametrize(("element", "line", "says"), [
    ('<group name="g"><joint name="knee"/></group>', 3, "joint 'knee' is not a joint of the robot"),
    ('<group_state name="home" group="g">\n<joint name="yaw" value="up"/></group_state>\n'
     '<group name="g"/>', 4,
     "joint 'yaw': value 'up' is not a number"),
    ('<end_effector name="e" parent_link="tip" group="hand"/>', 3,
     "<end_effector> names group 'hand', which the SRDF does not define"),
    ('<virtual_joint name="w" type="fixed" parent_frame="world" child_link="world_base"/>', 3,
     "link 'world_base' is not a link of the robot"),
    ('<disable_collisions link1="panda_link1" link2="panda_link0" reason="Adjacent"/>', 3,
     "link 'panda_link1' is not a link of the robot"),
])
def test_srdf_names_checked_with_line(tmp_path: Path, element: str, line: int, says: str) -> None:
    """An SRDF whose names are mostly not the robot's (here all), a group it does not define, a value that
    is no number: refused with the file and line."""
    p = tmp_path / "r.srdf"
    p.write_text(f'<?xml version="1.0"?>\n<robot name="r">\n{element}\n</robot>\n')
    with pytest.raises(SrdfError) as ei:
        read_srdf(p, LINKS, JOINTS)
    assert ei.value.code == "E_SRDF" and ei.value.data["line"] == line
    assert ei.value.message.startswith(f"{p}:{line}: {says}")


def test_virtual_joints_count_and_stateless_groups_skipped(tmp_path: Path) -> None:
    """A group may name the SRDF's virtual joint; a group_state of no group is skipped, as MoveIt does."""
    p = tmp_path / "v.srdf"
    p.write_text('<robot name="r"><virtual_joint name="world_joint" type="fixed" parent_frame="world" '
                 'child_link="base"/><group name="all"><joint name="world_joint"/><joint name="yaw"/></group>'
                 '<group_state name="x"><joint name="yaw" value="0"/></group_state></robot>')
    s = read_srdf(p, LINKS, JOINTS)
    assert s.groups["all"].joints == ["world_joint", "yaw"] and s.group_states == {}


def test_robot_description_of_a_launch_file(tmp_path: Path) -> None:
    """MoveIt 1's planning_context.launch: the robot_description param's $(find PKG)/file and its literal
    xacro args (a launch substitution left to the xacro's default); the semantic description is not it."""
    cfg = tmp_path / "arm_moveit_config"
    (cfg / "launch").mkdir(parents=True)
    (cfg / "config").mkdir()
    shutil.copy(CONFIG / "config" / "tinyxacro.srdf", cfg / "config" / "arm.srdf")
    (cfg / "launch" / "planning_context.launch").write_text(
        '<launch>\n  <arg name="robot_description" default="robot_description"/>\n'
        '  <param name="$(arg robot_description)_semantic"\n'
        '         textfile="$(find arm_moveit_config)/config/arm.srdf"/>\n'
        '  <param name="$(arg robot_description)" command="xacro \'$(find tinyxacro_description)/urdf/'
        'arm.urdf.xacro\' upper_length:=0.2 with_tool:=$(arg tool)"/>\n</launch>\n')
    c = find_moveit_config(cfg, {"tinyxacro_description": str(DESCRIPTION)})
    assert (c.urdf, c.xacro_args) == (DESCRIPTION / "urdf" / "arm.urdf.xacro", {"upper_length": "0.2"})
    assert c.srdf == cfg / "config" / "arm.srdf"


def test_position_limits_bound_a_joint_and_make_a_continuous_one_revolute(tmp_path: Path) -> None:
    """ros2_control's ``has_position_limits`` keys are read; the expansion writes them into ``<limit>``, a
    continuous joint becoming revolute (its limits would be ignored); a fixed joint, an unknown one and
    min >= max are refused naming the joint."""
    import xml.etree.ElementTree as ET

    from robwot_sim.model.moveit_config import joint_limits

    f = tmp_path / "joint_limits.yaml"
    f.write_text("joint_limits:\n  yaw:\n    has_position_limits: true\n    min_position: -1.5\n"
                 "    max_position: 1.25\n  elbow:\n    has_position_limits: false\n    min_position: 0\n"
                 "    max_position: 0.1\n")
    limits = joint_limits(f)
    assert limits.positions == {"yaw": (-1.5, 1.25)}
    source = tmp_path / "arm.urdf"
    source.write_text(
        '<robot name="a"><link name="b"/><link name="t"/><link name="u"/>'
        '<joint name="yaw" type="continuous"><parent link="b"/><child link="t"/><axis xyz="0 0 1"/></joint>'
        '<joint name="bolt" type="fixed"><parent link="t"/><child link="u"/></joint></robot>')
    urdf, _ = expand_xacro(source, {}, {}, {}, limits.positions)
    yaw = next(j for j in ET.parse(urdf).getroot().iter("joint") if j.get("name") == "yaw")
    limit = yaw.find("limit")
    assert yaw.get("type") == "revolute" and limit is not None
    assert (float(limit.get("lower", "nan")), float(limit.get("upper", "nan"))) == (-1.5, 1.25)
    with pytest.raises(UrdfError, match="fixed joint 'bolt'"):
        expand_xacro(source, {}, {}, {}, {"bolt": (0.0, 1.0)})
    with pytest.raises(UrdfError, match="names joint 'knee'"):
        expand_xacro(source, {}, {}, {}, {"knee": (0.0, 1.0)})
    f.write_text("joint_limits:\n  yaw:\n    has_position_limits: true\n    min_position: 2\n"
                 "    max_position: 1\n")
    with pytest.raises(UrdfError, match=r"min_position 2\.0 must be below max_position 1\.0"):
        joint_limits(f)
    f.write_text("joint_limits:\n  yaw:\n    has_position_limits: true\n    min_position: -1\n")
    with pytest.raises(UrdfError, match="max_position None must be a number"):
        joint_limits(f)


def test_the_shipped_m1_pro_limits_file_reads() -> None:
    """examples/limits/dobot_m1pro.yaml (README "The paper's robots"): three rotary joints bounded."""
    from robwot_sim.model.moveit_config import joint_limits

    limits = joint_limits(Path(__file__).resolve().parents[2] / "examples" / "limits" / "dobot_m1pro.yaml")
    assert set(limits.positions) == {"joint2", "joint3", "joint4"} and not limits.velocities
    assert limits.positions["joint3"] == (-2.3562, 2.3562)
