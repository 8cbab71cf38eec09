"""program.plan (program.py): steps planned one after the other from where each previous one ends, their
durations those of the joint paths a move runs, the first refused step named; the robot never moves."""

from __future__ import annotations

import pytest
from rpc_backend import RpcClient

START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]


def program(client: RpcClient) -> list[dict[str, object]]:
    """PTP to joints, LIN 15 cm along y, CIRC back through a point 6 cm up, PTP home."""
    pose = client.call("robot.fk", {"robot": "kuka", "positions": START})["position"]
    x, y, z = pose
    return [{"target": START, "speed": 0.5},
            {"motion": "lin", "position": [x, y + 0.15, z]},
            {"motion": "circ", "via": [x, y + 0.075, z + 0.06], "position": [x, y, z]},
            {"target": [0.0] * 7}]


def test_a_valid_program_has_step_durations_a_cycle_time_and_a_trajectory(client: RpcClient) -> None:
    before = client.call("robot.getJointPositions", {"robot": "kuka"})["positions"]
    plan = client.call("program.plan", {"robot": "kuka", "steps": program(client), "rate": 50})
    assert plan["valid"] and plan["firstFailingStep"] is None
    assert [s["planned"] for s in plan["steps"]] == ["straight", "lin", "circ", "straight"]
    assert plan["cycleTime"] == pytest.approx(sum(s["duration"] for s in plan["steps"]))
    assert all(s["duration"] > 0 for s in plan["steps"])
    traj = plan["trajectory"]
    assert traj["names"][0] == "lbr_iiwa_joint_1" and traj["rate"] == pytest.approx(50, rel=0.05)
    assert traj["positions"][0] == pytest.approx(before) and traj["positions"][-1] == pytest.approx([0.0] * 7)
    assert len(traj["positions"]) == pytest.approx(plan["cycleTime"] * traj["rate"], abs=2)
    # planned, not moved
    assert client.call("robot.getJointPositions", {"robot": "kuka"})["positions"] == pytest.approx(before)


def test_the_first_refused_step_is_named_with_its_reason(client: RpcClient) -> None:
    client.call("robot.setJointPositions", {"robot": "kuka", "positions": START})  # step 0 stays put
    steps = program(client)
    pose = steps[1]["position"]
    assert isinstance(pose, list)
    client.call("obstacle.add", {"name": "wall", "shape": {"type": "box", "size": [0.3, 0.02, 0.3]},
                                 "position": [pose[0], pose[1] - 0.07, pose[2]]})
    plan = client.call("program.plan", {"robot": "kuka", "steps": steps})
    assert not plan["valid"] and plan["firstFailingStep"] == 1
    assert len(plan["steps"]) == 2 and plan["steps"][0]["ok"] and not plan["steps"][1]["ok"]
    assert plan["steps"][1]["reasons"][0].startswith("LIN refused: the line collides (") and "wall" in \
        plan["steps"][1]["reasons"][0]
    assert plan["cycleTime"] == pytest.approx(plan["steps"][0]["duration"])


def test_steps_that_make_no_sense_are_refused_naming_the_step(client: RpcClient) -> None:
    no_via = [{"target": START}, {"motion": "circ", "position": [0.5, 0, 0.5]}]
    err = client.error("program.plan", {"robot": "kuka", "steps": no_via})
    assert err.data["param"] == "steps[1].via"
    err = client.error("program.plan", {"robot": "kuka", "steps": [{"motion": "lin", "target": START}]})
    assert err.data["param"] == "steps[0].target"
