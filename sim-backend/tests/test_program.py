"""program.plan (program.py): steps planned one after the other from where each previous one ends, their
durations those of the joint paths a move runs, the first refused step named; the robot never moves."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
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


def _slices(plan: dict[str, Any], dt: float) -> list[slice]:
    """The states of each step in a trajectory sampled every ``dt`` (each from its start to its end)."""
    out, start = [], 0
    for s in plan["steps"]:
        n = round(s["duration"] / dt)
        out.append(slice(start, start + n + 1))
        start += n
    return out


def _fk(client: RpcClient, states: Any) -> list[dict[str, Any]]:
    return [client.call("robot.fk", {"robot": "kuka", "positions": [float(v) for v in q]}) for q in states]


def test_every_step_keeps_the_velocity_and_acceleration_limits_and_lin_and_circ_keep_their_curve(
        client: RpcClient) -> None:
    """The full-rate trajectory: no joint beyond its velocity limit x speed nor its acceleration limit (the
    KUKA has none in a joint_limits.yaml: each reaches its velocity limit in 0.25 s); by forward
    kinematics of every state, the LIN within 0.5 mm of its line and the CIRC of its arc, the orientation
    within 0.5 degrees of the start's (kept); at rest where each step ends."""
    dt = 1 / 240
    steps = program(client)
    plan = client.call("program.plan", {"robot": "kuka", "steps": steps, "dt": dt, "rate": 1 / dt})
    assert plan["valid"]
    q = np.asarray(plan["trajectory"]["positions"])
    model = client.call("robot.model", {"robot": "kuka"})
    vmax = np.array([j["velocity"] for j in model["joints"] if j["name"] in model["controllable"]])
    parts = _slices(plan, dt)
    for k, part in enumerate(parts):
        speed = float(steps[k].get("speed", 1.0))  # type: ignore[arg-type]
        vel = np.diff(q[part], axis=0) / dt
        assert np.all(np.abs(vel) <= vmax * speed * 1.01 + 1e-9), k
        acc = np.diff(vel, axis=0) / dt
        assert np.all(np.abs(acc) <= vmax / 0.25 * 1.05 + 1e-6), (k, np.abs(acc).max(axis=0))
    fk = _fk(client, q[parts[1]])
    p = np.array([f["position"] for f in fk])
    a, b = p[0], np.asarray(steps[1]["position"])
    u = (b - a) / np.linalg.norm(b - a)
    off_line = np.linalg.norm((p - a) - ((p - a) @ u)[:, None] * u[None, :], axis=1)
    assert off_line.max() <= 0.0005
    r0 = np.array(fk[0]["orientation"])
    turn = [2 * math.degrees(math.acos(min(1.0, abs(float(np.dot(r0, f["orientation"])))))) for f in fk]
    assert max(turn) <= 0.5
    fk = _fk(client, q[parts[2]])
    p = np.array([f["position"] for f in fk])
    via = np.asarray(steps[2]["via"])
    # the circle through start, via and target: all states at its radius from its centre, in its plane
    a, c = p[0], p[-1]
    n = np.cross(via - a, c - via)
    n /= np.linalg.norm(n)
    m = np.array([via - a, c - via, n])
    rhs = np.array([(via @ via - a @ a) / 2, (c @ c - via @ via) / 2, n @ a])
    centre = np.linalg.solve(m, rhs)
    radius = np.linalg.norm(a - centre)
    assert np.abs(np.linalg.norm(p - centre, axis=1) - radius).max() <= 0.0005
    assert np.abs((p - a) @ n).max() <= 0.0005


def test_the_total_tcp_acceleration_stays_within_its_limit_on_an_arc_and_at_a_blend(
        client: RpcClient) -> None:
    """A tight CIRC (5 cm radius) at 0.5 m/s and two LINs blended at a right angle: by forward kinematics of
    every state (second differences at 1/240 s), the end effector's total acceleration, tangential and
    centripetal, stays within 1.2 m/s^2 (it reached 1.7x on an arc and about 4x at blends when only the
    tangential part was limited)."""
    dt = 1 / 240
    client.call("robot.setJointPositions", {"robot": "kuka", "positions": START})
    x, y, z = client.call("robot.fk", {"robot": "kuka", "positions": START})["position"]
    arc = [{"motion": "circ", "via": [x, y + 0.05, z + 0.05], "position": [x, y + 0.1, z], "tcpSpeed": 0.5}]
    corner = [{"motion": "lin", "position": [x, y + 0.1, z], "tcpSpeed": 0.3, "blend": 0.03},
              {"motion": "lin", "position": [x - 0.1, y + 0.1, z], "tcpSpeed": 0.3}]
    for steps in (arc, corner):
        plan = client.call("program.plan", {"robot": "kuka", "steps": steps, "dt": dt, "rate": 1 / dt})
        assert plan["valid"], plan["steps"]
        p = np.array([f["position"] for f in _fk(client, np.asarray(plan["trajectory"]["positions"]))])
        acc = np.linalg.norm(np.diff(p, n=2, axis=0), axis=1) / dt**2
        assert acc.max() <= 1.2 * 1.05, acc.max()


def test_a_lin_the_joints_cannot_keep_at_its_speed_is_refused_naming_the_joint(client: RpcClient) -> None:
    """At 3 m/s along a 15 cm line at 10 % of the velocity limits, some joint would need more than its
    limit: refused as step 1, naming the joint and tcpSpeed; at the default speed it passes."""
    steps = program(client)[:2]
    steps[0]["speed"] = 0.1
    steps[1] = {**steps[1], "speed": 0.1, "tcpSpeed": 3.0}
    plan = client.call("program.plan", {"robot": "kuka", "steps": steps})
    assert plan["firstFailingStep"] == 1
    reason = plan["steps"][1]["reasons"][0]
    assert reason.startswith("LIN refused: joint lbr_iiwa_joint_") and "tcpSpeed" in reason
    steps[1]["tcpSpeed"] = 0.25
    steps[1]["speed"] = 1.0
    assert client.call("program.plan", {"robot": "kuka", "steps": steps})["valid"]


def test_a_lower_acceleration_or_tcp_speed_makes_a_step_longer(client: RpcClient) -> None:
    steps = program(client)[:2]
    base = client.call("program.plan", {"robot": "kuka", "steps": steps})["steps"]
    slow = client.call("program.plan", {"robot": "kuka", "steps": [
        {**steps[0], "acceleration": 0.2}, {**steps[1], "tcpSpeed": 0.1}]})["steps"]
    assert slow[0]["duration"] > base[0]["duration"] and slow[1]["duration"] > base[1]["duration"]


def test_a_run_takes_the_cycle_time_it_was_validated_with(client: RpcClient) -> None:
    """program.run at real time 1: the simulated duration equals program.plan's cycle time, the wall time
    follows it (the bench measures how closely: `npm run bench:program`), and the states name the step
    running, in order; the robot ends at the last target."""
    steps = program(client)
    plan = client.call("program.plan", {"robot": "kuka", "steps": steps})
    client.notifications.clear()
    t0 = time.monotonic()
    run = client.call("program.run", {"robot": "kuka", "steps": steps, "realtime": 1})
    wall = time.monotonic() - t0
    assert run["status"] == "reached" and run["step"] == 3
    assert run["duration"] == pytest.approx(plan["cycleTime"], abs=1e-9)
    assert run["program"]["cycleTime"] == pytest.approx(plan["cycleTime"], abs=1e-9)
    assert run["wallTime"] == pytest.approx(plan["cycleTime"], rel=0.1)
    assert wall >= plan["cycleTime"]
    seen = [p["step"] for m, p in client.notifications if m == "robot.state" and p["robot"] == "kuka"]
    assert seen == sorted(seen) and set(seen) == {0, 1, 2, 3}
    assert client.call("robot.getJointPositions", {"robot": "kuka"})["positions"] == pytest.approx([0.0] * 7)


def test_a_refused_program_does_not_move_and_a_stop_ends_a_run(client: RpcClient) -> None:
    steps = program(client)
    before = client.call("robot.getJointPositions", {"robot": "kuka"})["positions"]
    bad = [*steps[:1], {"target": [0.0, 3.0, 0, 0, 0, 0, 0]}]
    err = client.error("program.run", {"robot": "kuka", "steps": bad})
    assert err.data["code"] == "E_REJECTED" and err.data["program"]["firstFailingStep"] == 1
    assert err.data["reasons"][0].startswith("step 1: ")
    assert client.call("robot.getJointPositions", {"robot": "kuka"})["positions"] == pytest.approx(before)
    pending = client.send("program.run", {"robot": "kuka", "steps": steps, "realtime": 1})
    time.sleep(0.5)
    assert client.call("robot.stop", {"robot": "kuka"})["stopped"]
    run = client.wait(pending)
    assert run["status"] == "stopped" and run["duration"] < run["program"]["cycleTime"]


def test_blended_steps_run_through_without_stopping_and_take_less_time(client: RpcClient) -> None:
    """A square of four LINs: with blend radii the run does not stop at the corners (its speed stays above
    zero through them), stays within each radius of the corner (by forward kinematics), is faster than the
    unblended program, and runs in its cycle time. (That blended motions touch nothing is measured against
    the exact-mesh reference in test_program_fidelity.py.)"""
    client.call("robot.setJointPositions", {"robot": "kuka", "positions": START})
    x, y, z = client.call("robot.fk", {"robot": "kuka", "positions": START})["position"]
    corners = [[x, y + 0.1, z], [x - 0.1, y + 0.1, z], [x - 0.1, y, z], [x, y, z]]
    sharp = [{"motion": "lin", "position": c, "tcpSpeed": 0.2} for c in corners]
    round_ = [{**s, "blend": 0.03} for s in sharp[:-1]] + [sharp[-1]]
    dt = 1 / 240
    a = client.call("program.plan", {"robot": "kuka", "steps": sharp, "dt": dt, "rate": 1 / dt})
    b = client.call("program.plan", {"robot": "kuka", "steps": round_, "dt": dt, "rate": 1 / dt})
    assert a["valid"] and b["valid"], b["steps"]
    assert b["cycleTime"] < 0.85 * a["cycleTime"]
    assert [s.get("blended", False) for s in b["steps"]] == [True, True, True, False]
    q = np.asarray(b["trajectory"]["positions"])
    p = np.array([f["position"] for f in _fk(client, q)])
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / dt
    for c in corners[:3]:
        near = int(np.argmin(np.linalg.norm(p - np.asarray(c), axis=1)))
        assert 0.01 < np.linalg.norm(p[near] - np.asarray(c)) <= 0.03  # rounded, within the radius
        assert speed[near - 1] > 0.05  # not at rest at the corner
    run = client.call("program.run", {"robot": "kuka", "steps": round_, "realtime": 0, "dt": dt})
    assert run["status"] == "reached" and run["duration"] == pytest.approx(b["cycleTime"], abs=1e-9)


def test_a_ptp_blended_after_a_lin_runs_at_its_joint_limits_not_at_the_lins_tcp_speed(
        client: RpcClient) -> None:
    """A slow LIN (5 cm/s) blended into a long PTP: each step keeps its own limits, so the PTP's part of
    the blended motion takes about what the PTP alone takes (it took 2.6 times as long when the whole
    group was held to the LIN's TCP speed) and moves the end effector far faster than the LIN's speed."""
    client.call("robot.setJointPositions", {"robot": "kuka", "positions": START})
    x, y, z = client.call("robot.fk", {"robot": "kuka", "positions": START})["position"]
    lin = {"motion": "lin", "position": [x, y + 0.05, z], "tcpSpeed": 0.05}
    ptp = {"target": [1.2, 0.3, 0.0, -1.0, 0.0, 0.8, 0.0]}
    dt = 1 / 240
    sharp = client.call("program.plan", {"robot": "kuka", "steps": [lin, ptp], "dt": dt, "rate": 1 / dt})
    round_ = client.call("program.plan", {"robot": "kuka", "steps": [{**lin, "blend": 0.015}, ptp],
                                          "dt": dt, "rate": 1 / dt})
    assert sharp["valid"] and round_["valid"], round_["steps"]
    assert round_["steps"][0].get("blended")
    assert round_["steps"][1]["duration"] < 1.25 * sharp["steps"][1]["duration"]
    assert round_["cycleTime"] < 1.1 * sharp["cycleTime"]
    q = np.asarray(round_["trajectory"]["positions"])
    p = np.array([f["position"] for f in _fk(client, q)])
    speed = np.linalg.norm(np.diff(p, axis=0), axis=1) / dt
    assert speed.max() > 5 * 0.05


def test_a_step_beyond_the_reach_or_the_joint_limits_is_the_first_failing_one(client: RpcClient) -> None:
    """Step 2 a pose 2 m up (beyond the reach), or step 1 a joint target beyond a limit: refused as that
    step, with the distance beyond the reach or the joint and its limits named."""
    steps = program(client)
    far = [*steps[:2], {"position": [0.0, 0.0, 2.0]}, *steps[2:]]
    plan = client.call("program.plan", {"robot": "kuka", "steps": far})
    assert plan["firstFailingStep"] == 2 and "beyond the robot's reach" in plan["steps"][2]["reasons"][0]
    outside = [steps[0], {"target": [0.0, 2.5, 0, 0, 0, 0, 0]}]
    plan = client.call("program.plan", {"robot": "kuka", "steps": outside})
    assert plan["firstFailingStep"] == 1 and "lbr_iiwa_joint_2" in plan["steps"][1]["reasons"][0]
