"""A tool mounted on the end effector (tool.py): the TCP is the end effector at its offset from the flange,
the tool's mesh collides with the scene like a link, never with the flange it is mounted on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_sim_decompose import box, to_obj

from robwot_sim.errors import MeshError, UnknownLink, UrdfError
from robwot_sim.model.rotations import quat_matrix, rpy_matrix
from robwot_sim.model.tool import TCP_LINK, TOOL_LINK, attach_tool
from robwot_sim.model.urdf import pybullet_data_path
from robwot_sim.sim.world import World

KUKA = pybullet_data_path() / "kuka_iiwa/model.urdf"
TCP = (0.0, 0.0, 0.2, 0.0, np.pi / 2, 0.0)


@pytest.fixture
def gripper(tmp_path: Path) -> Path:
    """A 6 x 6 x 20 cm block below the flange (z 0 .. 0.2 m in its frame)."""
    f = tmp_path / "gripper.obj"
    f.write_text(to_obj(*box([-0.03, -0.03, 0.0], [0.03, 0.03, 0.2])))
    return f


def test_the_tcp_is_the_end_effector_at_its_offset_from_the_flange(gripper: Path) -> None:
    tool = attach_tool(KUKA, {}, "lbr_iiwa_link_7", TCP, gripper)
    try:
        assert (tool.flange, tool.tcp_link) == ("lbr_iiwa_link_7", TCP_LINK)
        q = [0.3, 0.5, -0.2, -1.0, 0.4, 0.6, 0.1]
        with World() as w:
            bare = w.load_robot(str(KUKA))
            tooled = w.load_robot(str(tool.urdf), package_roots=tool.package_roots, ee_link=tool.tcp_link)
            assert tooled.ee_link == TCP_LINK and TOOL_LINK in tooled.links
            flange, tcp = w.fk(bare.id, q), w.fk(tooled.id, q)
            rot = quat_matrix(flange.quat_xyzw)
            assert np.allclose(tcp.position, np.asarray(flange.position) + rot @ [0, 0, 0.2], atol=1e-6)
            assert np.allclose(quat_matrix(tcp.quat_xyzw), rot @ rpy_matrix(*TCP[3:]), atol=1e-6)
    finally:
        tool.urdf.unlink()


def test_the_tool_collides_with_the_scene_but_not_with_its_flange(gripper: Path) -> None:
    tool = attach_tool(KUKA, {}, None, TCP, gripper)  # the default end effector: link 7
    q = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]
    with World() as w:
        bare = w.load_robot(str(KUKA), robot_id="bare")
        tooled = w.load_robot(str(tool.urdf), package_roots=tool.package_roots, ee_link=tool.tcp_link,
                              robot_id="tooled", base_position=[0, 3, 0])
        assert w.check_collision(tooled.id, q).collision_free  # the gripper on link 7: no self contact
        tcp = np.asarray(w.fk(tooled.id, q).position)
        flange = np.asarray(w.fk(bare.id, q).position) + np.array([0.0, 3.0, 0.0])
        middle = (tcp + flange) / 2  # inside the gripper, 10 cm beyond the flange
        ball = {"type": "sphere", "radius": 0.02}
        w.add_obstacle({"name": "ball", "shape": ball, "position": list(middle)})
        report = w.check_collision(tooled.id, q)
        assert not report.collision_free
        assert {c.a.link for c in report.contacts} | {c.b.link for c in report.contacts} >= {TOOL_LINK}
        # the bare robot's flange at the same pose (3 m away) does not reach the ball
        w.move_obstacle("ball", list(middle - [0, 3, 0]))
        assert w.check_collision(bare.id, q).collision_free


def test_refusals_name_the_problem(gripper: Path, tmp_path: Path) -> None:
    with pytest.raises(UnknownLink):
        attach_tool(KUKA, {}, "no_such_link", TCP, gripper)
    bad = tmp_path / "bad.stl"
    bad.write_bytes(b"\0" * 80 + (1000).to_bytes(4, "little"))
    with pytest.raises(MeshError):
        attach_tool(KUKA, {}, None, TCP, bad)
    twice = attach_tool(KUKA, {}, None, TCP)
    with pytest.raises(UrdfError, match="already has a link named 'robwot_tcp'"):
        attach_tool(twice.urdf, {}, None, TCP)


def test_a_primitive_tool_extends_from_the_flange_along_its_z_axis() -> None:
    """A 20 cm cylinder from the flange: a ball 15 cm out along the flange's z axis touches it, one 25 cm
    out does not; the TCP may be given alone (no geometry: no robwot_tool link)."""
    tool = attach_tool(KUKA, {}, None, (0, 0, 0.2, 0, 0, 0), shape={"type": "cylinder", "radius": 0.02,
                                                                     "length": 0.2})
    bare = attach_tool(KUKA, {}, None, (0, 0, 0.2, 0, 0, 0))
    q = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]
    with World() as w:
        m = w.load_robot(str(tool.urdf), package_roots=tool.package_roots, ee_link=tool.tcp_link)
        assert TOOL_LINK in m.links
        assert TOOL_LINK not in w.load_robot(str(bare.urdf), package_roots=bare.package_roots,
                                             ee_link=bare.tcp_link, base_position=[0, 3, 0]).links
        assert w.check_collision(m.id, q).collision_free
        pose = w.fk(m.id, q)  # the TCP: 20 cm out along the flange's z axis
        axis = quat_matrix(pose.quat_xyzw)[:, 2]
        flange = np.asarray(pose.position) - 0.2 * axis
        ball = {"type": "sphere", "radius": 0.01}
        w.add_obstacle({"name": "near", "shape": ball, "position": list(flange + 0.15 * axis)})
        assert any(TOOL_LINK in (c.a.link, c.b.link) for c in w.check_collision(m.id, q).contacts)
        w.move_obstacle("near", list(flange + 0.25 * axis))
        assert w.check_collision(m.id, q).collision_free
