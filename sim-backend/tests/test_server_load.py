"""`robot.load` / `world.loadScene` over the wire while a first load decomposes a concave mesh."""

from __future__ import annotations

from pathlib import Path

import pytest
from rpc_backend import BackendProcess
from test_sim_decompose import to_obj, u_shape

URDF = """<?xml version="1.0"?>
<robot name="u_arm">
  <link name="base"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="u"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="u">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><mesh filename="u.obj"/></geometry></collision>
  </link>
</robot>
"""


def test_a_first_load_decomposing_a_mesh_does_not_hold_the_loop(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot's first load splits its concave meshes into convex parts (the KUKA: minutes) in a worker
    thread: a ping sent after the load is answered before it, as the CLI's and the servient's heartbeats
    are (the 30 s heartbeat used to end the first `robwot generate` of the KUKA on a fresh machine)."""
    (tmp_path / "u.obj").write_text(to_obj(*u_shape()))
    (tmp_path / "u_arm.urdf").write_text(URDF)
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path / "cache"))
    proc = BackendProcess()
    try:
        client = proc.client()
        load = client.send("robot.load", {"urdf": str(tmp_path / "u_arm.urdf"), "id": "u"})
        ping = client.send("ping")
        client.wait(ping, timeout=10)
        assert load not in client.replies  # the ping's answer came first
        model = client.wait(load, timeout=300)
        assert model["id"] == "u"
        assert any((tmp_path / "cache").rglob("*.obj"))  # it decomposed (a fresh cache), not a cached load
        # the caller heard of it: the start, then the mesh with its parts and an estimate of the time left
        progress = [p for m, p in client.notifications if m == "robot.loadProgress"]
        assert [(p["done"], p["total"]) for p in progress] == [(0, 1), (1, 1)]
        assert progress[1]["mesh"] == "u.obj" and progress[1]["parts"] >= 2 and progress[1]["eta"] == 0
        assert 0 < progress[1]["seconds"] <= progress[1]["elapsed"]
        # each report names the collision cache folder the parts go to: the one this load used
        assert {p["cache"] for p in progress} == {str(tmp_path / "cache")}
        # a second load of the same robot finds its parts cached: nothing to report
        client.notifications.clear()
        client.wait(client.send("robot.load", {"urdf": str(tmp_path / "u_arm.urdf"), "id": "u2"}), timeout=60)
        assert not [m for m, _ in client.notifications if m == "robot.loadProgress"]
        client.close()
    finally:
        assert proc.stop() == 0
