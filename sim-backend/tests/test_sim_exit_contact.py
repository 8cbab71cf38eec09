"""A robot whose current state collides may move out of it while the contact recedes, nothing else."""

from __future__ import annotations

from rpc_backend import RpcClient

from robwot_sim.sim.exit_contact import receding
from robwot_sim.sim.planner import plan_joints
from robwot_sim.sim.types import BodyLink
from robwot_sim.sim.world import World

KUKA = "kuka_iiwa/model.urdf"
#: a box through the KUKA's links 2 and 3 at its start (all joints 0), on the +x side of the arm
BOX = {"name": "box", "shape": {"type": "box", "size": [0.1, 0.3, 0.1]}, "position": [0.09, 0.0, 0.55]}
#: joint 2 tilting the arm away from the box (free target) and through it (free target beyond it)
AWAY = [0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
THROUGH = [0.0, 1.2, 0.0, 0.0, 0.0, 0.0, 0.0]
ARM, BOXSIDE, TABLE = BodyLink("r", "link_3"), BodyLink("box", None), BodyLink("table", None)


def test_penetration_must_fall_and_nothing_new_may_touch() -> None:
    """The summed depth must fall strictly; a pair not touching before refuses the step."""
    before = {(ARM, BOXSIDE): 0.02}
    assert receding(before, {(ARM, BOXSIDE): 0.019})
    assert receding(before, {})
    assert not receding(before, {(ARM, BOXSIDE): 0.02})
    assert not receding(before, {(ARM, BOXSIDE): 0.021})
    assert not receding(before, {(ARM, BOXSIDE): 0.001, (ARM, TABLE): 0.001})


def test_a_path_out_of_a_colliding_start_is_allowed_and_one_deeper_is_refused_naming_the_start() -> None:
    """The KUKA loaded with a box through it: tilting away (its penetration falling until free) is a valid
    plan whose path is checked like any other once free; tilting through the box (deeper first) is
    refused, the reason saying the current state collides and naming the box, with no detour searched."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(BOX)
        start = w.check_collision(m.id)
        assert not start.collision_free and {c.b.body for c in start.contacts} == {"box"}
        assert all(w.check_collision(m.id, q).collision_free for q in (AWAY, THROUGH))
        out = plan_joints(w, m.id, AWAY, 1.0, 1 / 240)
        assert out.valid and out.path is not None
        report = w.check_states(m.id, out.path)
        assert report.collision_free and {c.b.body for c in report.start_contacts} == {"box"}
        deeper = plan_joints(w, m.id, THROUGH, 1.0, 1 / 240)
        assert not deeper.valid and deeper.checks["path"]["detour"] == "not searched"
        assert deeper.reasons[0].startswith("the current state already collides (lbr_iiwa/lbr_iiwa_link_")
        assert "box" in deeper.reasons[0] and "recedes" in deeper.reasons[0]


def test_a_path_leaving_the_contact_then_hitting_something_else_is_refused() -> None:
    """After the exit the normal check applies: a wall on the far side of the way out refuses the path,
    naming the wall, not the box."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(BOX)
        p = w.fk(m.id, [0.0, -0.8, 0.0, 0.0, 0.0, 0.0, 0.0]).position
        wall = {"name": "wall", "shape": {"type": "box", "size": [0.1, 0.4, 0.1]}, "position": list(p)}
        w.add_obstacle(wall)
        report = w.check_path(m.id, AWAY)
        assert not report.collision_free and report.first_collision is not None
        assert report.first_collision.time > 0
        assert {c.b.body for c in report.first_collision.contacts} == {"wall"}


def test_a_twin_loaded_into_a_box_moves_out_over_the_wire(client: RpcClient) -> None:
    """Through the real backend: robot.move out of the box runs and reaches its target; a move deeper
    is refused (E_REJECTED) saying that the current state collides."""
    client.call("obstacle.add", BOX)
    err = client.error("robot.move", {"robot": "kuka", "target": THROUGH, "realtime": 0})
    assert err.data["code"] == "E_REJECTED" and "the current state already collides" in err.data["reasons"][0]
    moved = client.call("robot.move", {"robot": "kuka", "target": AWAY, "realtime": 0})
    assert moved["status"] == "reached"
    assert client.call("robot.checkCollision", {"robot": "kuka"})["collisionFree"] is True
