"""Grippers: a Panda's fingers (from pybullet_data, with a TCP between its fingertips) catch the cube at the
TCP; the held cube is checked with the robot everywhere (single checks, batches through the mirror world,
IK) against everything but the hand, and settles where it is let go; closing on nothing, a robot without
finger joints, a second gripper on a held cube and a joint vector moving the fingers are defined outcomes."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rpc_backend import RpcClient
from simhelp import DATA, KUKA, PANDA, steps_of

from robwot_sim.errors import InvalidParams, Overlap
from robwot_sim.limits import DEFAULT_DT
from robwot_sim.model.tool import attach_tool
from robwot_sim.sim import loader
from robwot_sim.sim.program import plan_program
from robwot_sim.sim.world import World

DOWN = [1.0, 0.0, 0.0, 0.0]  # the hand's z axis pointing down
TABLE = {"name": "table", "shape": {"type": "box", "size": [0.4, 0.6, 0.3]}, "position": [0.5, 0.0, 0.15]}
CUBE = {"name": "cube", "shape": {"type": "box", "size": [0.04, 0.04, 0.04]}, "position": [0.5, 0.0, 0.4],
        "color": [1.0, 0.0, 0.0]}


@pytest.fixture
def world() -> Iterator[World]:
    """A Panda with its TCP 10.34 cm below the hand (between the fingertips), a table, a cube on it."""
    tool = attach_tool(DATA / PANDA, {}, "panda_hand", (0, 0, 0.1034, 0, 0, 0))
    with World() as w:
        w.load_robot(tool.urdf, robot_id="panda", ee_link=tool.tcp_link, package_roots=tool.package_roots)
        w.add_obstacle(TABLE)
        w.add_object(CUBE)
        yield w


def at(w: World, position: list[float], free: bool = True) -> tuple[float, ...]:
    """The Panda put with its TCP at ``position``, pointing down; its joints."""
    q = w.ik("panda", position, DOWN, collision_free=free).positions
    w.set_joint_positions("panda", q)
    return q


def test_fingers_are_found_and_open_is_the_wider_limit(world: World) -> None:
    out = world.grippers.configure("panda", "fingers")
    g = out["gripper"]
    assert g["joints"] == ["panda_finger_joint1"] and g["open"] == [0.04] and g["closed"] == [0.0]
    assert out["state"] == "open" and out["holding"] is None


def test_a_held_cube_moves_with_the_tcp_and_is_checked_with_the_robot(world: World) -> None:
    world.grippers.configure("panda", "fingers")
    at(world, [0.5, 0.0, 0.32])
    out = world.grippers.close("panda")
    assert out["holding"] == "cube"
    fingers = world.get_joint_positions("panda")[-1]
    assert 0.02 <= fingers < 0.025  # stopped at the cube (2 cm half width), neither open nor closed
    assert [o["name"] for o in world.list()["objects"]] == ["cube"]
    assert world.list()["objects"][0]["heldBy"] == "panda"
    # the fingers touch the cube: never a contact; the cube resting on the table is one, named
    contacts = world.check_collision("panda").contacts
    assert {(c.a.link, c.b.body) for c in contacts} == {("cube", "table")}
    lifted = at(world, [0.5, 0.0, 0.45])
    assert world.check_collision("panda").collision_free
    held = world.list()["objects"][0]
    assert held["position"] == pytest.approx([0.5, 0.0, 0.45], abs=1e-3)
    # lowered 2 cm into the table: the cube is the link that hits it first (the fingertips 1 cm)
    lowered = world.ik("panda", [0.5, 0.0, 0.30], DOWN, collision_free=False).positions
    report = world.check_collision("panda", lowered)
    deepest = max(report.contacts, key=lambda c: c.depth)
    assert (deepest.a.link, deepest.b.body) == ("cube", "table")
    assert deepest.depth == pytest.approx(0.02, abs=2e-3)
    free = world.collision_free_batch("panda", np.array([lifted, lowered]))
    assert free.tolist() == [True, False]


def test_a_grip_carries_the_robots_filtered_pairs_over_and_samples_nothing(
        world: World, monkeypatch: pytest.MonkeyPatch) -> None:
    """The body holding the cube is built from what the robot's own body knows: no always-colliding pair
    sampled again, the robot's own ones kept, the cube's pairs with the hand added, no other pair of it."""
    world.grippers.configure("panda", "fingers")
    own = {tuple(sorted(p)) for p in world.robot_model("panda").filtered_pairs}
    assert own == {("panda_hand", "panda_link7")}

    def sampled(*_: object) -> None:
        raise AssertionError("always-colliding pairs sampled again")

    monkeypatch.setattr(loader, "find_always_colliding", sampled)
    for _ in range(2):  # again with the body of the first grip freed
        at(world, [0.5, 0.0, 0.32])
        assert world.grippers.close("panda")["holding"] == "cube"
        held = {tuple(sorted(p)) for p in world.robot_model("panda").filtered_pairs}
        hand = ("panda_hand", "panda_leftfinger", "panda_rightfinger", "panda_grasptarget", "robwot_tcp")
        assert held == own | {tuple(sorted((h, "cube"))) for h in hand}
        world.grippers.open("panda")


def test_a_carried_cube_hitting_an_obstacle_the_hand_clears_is_refused(world: World) -> None:
    """A post just under the lifted cube: the cube touches it, the fingertips above its top do not."""
    world.grippers.configure("panda", "fingers")
    at(world, [0.5, 0.0, 0.32])
    world.grippers.close("panda")
    up = at(world, [0.5, 0.0, 0.55])
    world.add_obstacle({"name": "post", "shape": {"type": "box", "size": [0.05, 0.05, 0.05]},
                        "position": [0.5, 0.0, 0.51]})
    report = world.check_collision("panda", up)
    assert {(c.a.link, c.b.body) for c in report.contacts} == {("cube", "post")}
    with pytest.raises(Overlap, match=r"'cube'.*'post'"):  # let go 5 mm into the post: refused, still held
        world.grippers.open("panda")
    assert world.grippers.state("panda")["holding"] == "cube"
    after = world.check_collision("panda", up).contacts
    assert after == report.contacts
    ik = world.ik("panda", [0.5, 0.0, 0.55], DOWN)
    assert not ik.collision_free


def test_opening_lets_the_cube_go_where_it_is(world: World) -> None:
    world.grippers.configure("panda", "fingers")
    at(world, [0.5, 0.0, 0.32])
    world.grippers.close("panda")
    at(world, [0.5, 0.2, 0.5])
    out = world.grippers.open("panda")
    assert out["holding"] is None and out["state"] == "open"
    assert out["released"]["position"] == pytest.approx([0.5, 0.2, 0.32], abs=2e-3)  # on the table top
    assert world.list()["objects"] == [out["released"]]
    assert world.get_joint_positions("panda")[-1] == pytest.approx(0.04)


def test_closing_on_nothing_holds_nothing_and_closes_fully(world: World) -> None:
    world.grippers.configure("panda", "fingers")
    at(world, [0.3, 0.3, 0.5])
    out = world.grippers.close("panda")
    assert out["holding"] is None and out["state"] == "closed"
    assert world.get_joint_positions("panda")[-1] == pytest.approx(0.0)


def test_the_fingers_are_the_grippers_alone(world: World) -> None:
    """IK keeps the fingers; a joint vector that moves them is refused naming the joint."""
    world.grippers.configure("panda", "fingers")
    q = at(world, [0.4, 0.1, 0.5])
    assert q[-1] == pytest.approx(0.04)
    with pytest.raises(InvalidParams, match="panda_finger_joint1"):
        world.set_joint_positions("panda", [*q[:-1], 0.01])


def test_a_robot_without_finger_joints_has_no_finger_gripper_but_a_suction_cup() -> None:
    with World() as w:
        w.load_robot(KUKA, robot_id="kuka")
        with pytest.raises(InvalidParams, match="no finger joints"):
            w.grippers.configure("kuka", "fingers")
        with pytest.raises(InvalidParams, match="has no gripper"):
            w.grippers.close("kuka")
        assert w.grippers.configure("kuka", "suction")["gripper"]["joints"] == []


def test_a_cube_held_by_one_robot_is_not_caught_by_another(world: World) -> None:
    world.grippers.configure("panda", "fingers")
    at(world, [0.5, 0.0, 0.32])
    world.grippers.close("panda")
    tcp = world.fk("panda").position
    world.load_robot(KUKA, robot_id="kuka", base_position=[1.2, 0.0, 0.0])
    world.grippers.configure("kuka", "suction", capture=0.1)
    q = world.ik("kuka", tcp, collision_free=False).positions
    world.set_joint_positions("kuka", q)
    assert world.grippers.close("kuka")["holding"] is None


def test_gripper_methods_over_the_wire(client: RpcClient, tmp_path: Path) -> None:
    """configure / close / open / state through the contract (results checked against it)."""
    tool = client.call("robot.attachTool", {"urdf": str(DATA / PANDA), "eeLink": "panda_hand",
                                            "tcp": [0, 0, 0.1034, 0, 0, 0]})
    client.call("robot.load", {"urdf": tool["urdf"], "id": "panda", "eeLink": tool["tcpLink"],
                               "packageRoots": tool["packageRoots"], "basePosition": [0, 2, 0]})
    err = client.error("gripper.configure", {"robot": "kuka", "kind": "fingers"})
    assert err.data["code"] == "E_INVALID_PARAMS"
    out = client.call("gripper.configure", {"robot": "panda", "kind": "fingers", "time": 0.2})
    assert out["gripper"]["time"] == 0.2 and out["positions"][-1] == pytest.approx(0.04)
    closed = client.call("gripper.close", {"robot": "panda"})
    assert closed["holding"] is None and closed["state"] == "closed"
    assert client.call("gripper.state", {"robot": "panda"})["state"] == "closed"
    opened = client.call("gripper.open", {"robot": "panda"})
    assert opened["released"] is None and opened["positions"][-1] == pytest.approx(0.04)


def test_a_colour_sensor_reads_the_cube_a_robot_holds_up_to_it(world: World) -> None:
    """The paper's mashup shows the picked cube to the colour sensor: sensors see held objects."""
    world.load_scene({"version": 1, "sensors": [
        {"name": "eye", "kind": "color", "size": [0.06, 0.06, 0.06], "position": [0.3, 0.3, 0.6]}]})
    world.grippers.configure("panda", "fingers")
    at(world, [0.5, 0.0, 0.32])
    world.grippers.close("panda")
    at(world, [0.5, 0.0, 0.6])
    assert world.cell.advance(0.1)["sensors"][0]["object"] is None
    at(world, [0.3, 0.3, 0.6])
    out = world.cell.advance(0.1)
    assert out["sensors"][0]["object"] == "cube" and out["sensors"][0]["color"] == [255, 0, 0]
    assert [e["type"] for e in out["events"]] == ["detectedObject"]


def pick_and_place(place: list[float]) -> list[dict[str, Any]]:
    """A pick of the cube on the table and a place at ``place`` (the TCP's position there), hand down."""
    return [
        {"motion": "ptp", "position": [0.5, 0.0, 0.45], "orientation": DOWN},
        {"motion": "lin", "position": [0.5, 0.0, 0.32], "orientation": DOWN},
        {"motion": "grip"},
        {"motion": "lin", "position": [0.5, 0.0, 0.45], "orientation": DOWN},
        {"motion": "ptp", "position": place, "orientation": DOWN},
        {"motion": "release"},
    ]


def test_a_program_with_grip_and_release_steps_checks_every_later_step_with_the_cube(world: World) -> None:
    world.grippers.configure("panda", "fingers", time=0.2)
    before = world.list()["objects"]
    q0 = world.get_joint_positions("panda")
    steps = steps_of(pick_and_place([0.5, 0.2, 0.45]), 8)
    report = plan_program(world, "panda", steps, DEFAULT_DT, 50).report
    assert report["valid"], report["steps"]
    grip, release = report["steps"][2], report["steps"][5]
    assert (grip["planned"], grip["holding"]) == ("grip", "cube")
    assert grip["duration"] == pytest.approx(0.2, abs=0.02)
    assert (release["planned"], release["holding"]) == ("release", None)
    assert 0.015 < grip["target"][-1] < 0.025  # the fingers on the cube from the grip on
    # planning moved nothing: the cube on the table, nothing held, the robot where it was
    assert world.list()["objects"] == before and world.grippers.state("panda")["holding"] is None
    assert np.allclose(world.get_joint_positions("panda"), q0)
    # carried through the post: refused at that step, naming the cube (the empty hand passes above it)
    world.add_obstacle({"name": "post", "shape": {"type": "box", "size": [0.05, 0.05, 0.05]},
                        "position": [0.5, 0.16, 0.41]})
    through = plan_program(world, "panda", steps, DEFAULT_DT, 50).report
    assert through["firstFailingStep"] == 4
    why = " ".join(through["steps"][4]["reasons"])
    assert "cube" in why and "post" in why
    empty = [s for s in pick_and_place([0.5, 0.2, 0.45]) if s["motion"] not in ("grip", "release")]
    assert plan_program(world, "panda", steps_of(empty, 8), DEFAULT_DT, 50).report["valid"]


def test_a_run_program_grips_and_releases_the_cube_on_the_wire(client: RpcClient) -> None:
    tool = client.call("robot.attachTool", {"urdf": str(DATA / PANDA), "eeLink": "panda_hand",
                                            "tcp": [0, 0, 0.1034, 0, 0, 0]})
    client.call("world.reset")
    client.call("robot.load", {"urdf": tool["urdf"], "id": "panda", "eeLink": tool["tcpLink"],
                               "packageRoots": tool["packageRoots"]})
    client.call("obstacle.add", TABLE)
    client.call("object.add", CUBE)
    client.call("gripper.configure", {"robot": "panda", "kind": "fingers", "time": 0.1})
    err = client.error("program.plan", {"robot": "panda",
                                        "steps": [{"motion": "grip", "position": [0, 0, 1]}]})
    assert err.data["code"] == "E_INVALID_PARAMS" and "grip step has no 'position'" in str(err)
    out = client.call("program.run", {"robot": "panda", "steps": pick_and_place([0.5, 0.2, 0.45]),
                                      "realtime": 0})
    assert out["status"] == "reached"
    cube = next(o for o in client.call("world.list")["objects"] if o["name"] == "cube")
    assert cube["position"] == pytest.approx([0.5, 0.2, 0.32], abs=3e-3) and "heldBy" not in cube
    assert client.call("gripper.state", {"robot": "panda"})["state"] == "open"
