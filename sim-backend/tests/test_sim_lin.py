"""LIN (lin.py): the end effector on the straight line, measured by forward kinematics of the returned
waypoints and of the states between them; refusals name where and why."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from rpc_backend import RpcClient

from robwot_sim.model.rotations import quat_angle
from robwot_sim.model.urdf import pybullet_data_path
from robwot_sim.sim.lin import MAX_DEVIATION
from robwot_sim.sim.planner import plan_lin
from robwot_sim.sim.world import World

KUKA = str(pybullet_data_path() / "kuka_iiwa/model.urdf")
START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]


def distance_to_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = float(np.clip((p - a) @ (b - a) / max((b - a) @ (b - a), 1e-18), 0, 1))
    return float(np.linalg.norm(p - (a + t * (b - a))))


def test_the_tcp_stays_on_the_line_with_its_orientation() -> None:
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        start = w.fk(m.id)
        a = np.asarray(start.position)
        b = a + np.array([0.0, 0.3, -0.1])
        plan = plan_lin(w, m.id, tuple(b), None)
        assert plan.valid and plan.target is not None and plan.checks["path"]["planned"] == "lin"
        path = [np.asarray(START), *map(np.asarray, plan.via), np.asarray(plan.target)]
        assert len(path) > 60  # 5 mm samples along 316 mm
        worst, turn = 0.0, 0.0
        for qa, qb in itertools.pairwise(path):
            for t in np.linspace(0, 1, 5):  # the waypoints and the states the motion passes between them
                pose = w.fk(m.id, list(qa + t * (qb - qa)))
                worst = max(worst, distance_to_segment(np.asarray(pose.position), a, b))
                turn = max(turn, quat_angle(pose.quat_xyzw, start.quat_xyzw))
        assert worst <= MAX_DEVIATION
        assert np.degrees(turn) <= 0.5
        assert np.linalg.norm(np.asarray(w.fk(m.id, list(plan.target)).position) - b) <= 1e-4
        assert list(w.get_joint_positions(m.id)) == pytest.approx(START)  # read-only


def test_a_line_through_an_obstacle_is_refused_naming_it() -> None:
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        a = np.asarray(w.fk(m.id).position)
        b = a + np.array([0.0, 0.3, -0.1])
        w.add_obstacle({"name": "post", "shape": {"type": "box", "size": [0.3, 0.02, 0.3]},
                        "position": list(a + np.array([0.0, 0.15, -0.05]))})
        plan = plan_lin(w, m.id, tuple(b), None)
        assert not plan.valid
        assert plan.reasons[0].startswith("LIN refused: the line collides (") and "post" in plan.reasons[0]
        assert plan.checks["path"]["ok"] is False and plan.checks["path"]["planned"] == "lin"


def test_a_line_out_of_reach_is_refused_saying_where() -> None:
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        a = np.asarray(w.fk(m.id).position)
        plan = plan_lin(w, m.id, tuple(a + np.array([2.0, 0.0, 0.0])), None)
        assert not plan.valid
        # the arm stretched out to where its reach with this orientation ends: a singularity
        reason = plan.reasons[0]
        assert "LIN refused: the line cannot be followed" in reason and "a singularity" in reason, reason
        assert "mm along the line" in plan.reasons[0]


def test_lin_over_the_wire(client: RpcClient) -> None:
    """robot.plan / robot.move with motion 'lin': the move ends on the target pose; a joint target is
    refused for LIN."""
    client.call("robot.setJointPositions", {"robot": "kuka", "positions": START})  # the fixture's robot
    pose = client.call("robot.fk", {"robot": "kuka"})
    target = [pose["position"][0], pose["position"][1] + 0.2, pose["position"][2]]
    plan = client.call("robot.plan", {"robot": "kuka", "position": target, "motion": "lin"})
    assert plan["valid"], plan
    assert plan["checks"]["path"]["planned"] == "lin" and len(plan["via"]) > 30
    done = client.call("robot.move", {"robot": "kuka", "position": target, "motion": "lin", "realtime": 0})
    assert done["status"] == "reached"
    end = client.call("robot.fk", {"robot": "kuka"})
    assert np.linalg.norm(np.asarray(end["position"]) - target) <= 1e-3
    err = client.error("robot.plan", {"robot": "kuka", "target": START, "motion": "lin"})
    assert err.data["param"] == "target"  # one rule for a move and a program step


def test_circ_keeps_the_tcp_on_the_arc_through_the_via_point() -> None:
    """A half circle of 10 cm radius in the vertical y-z plane: every waypoint and every state between
    two of them within 0.5 mm of the circle, the via point passed, the target reached."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        a = np.asarray(w.fk(m.id).position)
        centre = a + np.array([0.0, 0.1, 0.0])
        via, end = centre + np.array([0.0, 0.0, 0.1]), centre + np.array([0.0, 0.1, 0.0])
        plan = plan_lin(w, m.id, tuple(end), None, tuple(via))
        assert plan.valid, plan.reasons
        assert plan.target is not None and plan.checks["path"]["planned"] == "circ"
        path = [np.asarray(START), *map(np.asarray, plan.via), np.asarray(plan.target)]
        off_circle, off_plane, nearest_via = 0.0, 0.0, np.inf
        for qa, qb in itertools.pairwise(path):
            for t in np.linspace(0, 1, 5):
                x = np.asarray(w.fk(m.id, list(qa + t * (qb - qa))).position)
                off_circle = max(off_circle, abs(float(np.linalg.norm(x - centre)) - 0.1))
                off_plane = max(off_plane, abs(float(x[0] - centre[0])))
                nearest_via = min(nearest_via, float(np.linalg.norm(x - via)))
        assert off_circle <= MAX_DEVIATION and off_plane <= MAX_DEVIATION
        assert nearest_via <= 0.003  # samples every 5 mm of arc: the via point lies between two
        assert np.linalg.norm(np.asarray(w.fk(m.id, list(plan.target)).position) - end) <= 1e-4


def test_circ_through_a_point_on_the_line_is_refused() -> None:
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        a = np.asarray(w.fk(m.id).position)
        end, via = a + np.array([0.0, 0.2, 0.0]), a + np.array([0.0, 0.1, 0.0])
        plan = plan_lin(w, m.id, tuple(end), None, tuple(via))
        assert not plan.valid
        assert plan.reasons[0].startswith("CIRC refused: the start, via point and target lie on one line")


def _pinocchio_reach_along_line(urdf: str, q0: np.ndarray, direction: np.ndarray, length: float) -> float:
    """How far (m) along the line from the end link's pose at ``q0`` (orientation kept) Pinocchio's own
    damped least squares follows it in 0.5 mm steps, each from the previous joints, within 0.1 mm: an IK
    independent of ours (model, Jacobian and solver)."""
    import pinocchio as pin

    model = pin.buildModelFromUrdf(urdf)
    data = model.createData()
    frame = model.getFrameId("wrist_3_link")
    pin.framesForwardKinematics(model, data, q0)
    start = data.oMf[frame].copy()
    q = q0.copy()
    for k in range(1, int(length / 0.0005) + 1):
        goal = pin.SE3(start.rotation, start.translation + direction * 0.0005 * k)
        for _ in range(50):
            pin.framesForwardKinematics(model, data, q)
            err = pin.log6(data.oMf[frame].actInv(goal)).vector
            if np.linalg.norm(err[:3]) < 1e-7 and np.linalg.norm(err[3:]) < 1e-6:
                break
            jac = pin.computeFrameJacobian(model, data, q, frame, pin.LOCAL)
            q = q + jac.T @ np.linalg.solve(jac @ jac.T + 1e-8 * np.eye(6), err)
        pin.framesForwardKinematics(model, data, q)
        if np.linalg.norm(pin.log6(data.oMf[frame].actInv(goal)).vector[:3]) > 1e-4:
            return 0.0005 * (k - 1)
    return length


def test_a_line_the_robot_cannot_follow_is_refused_where_its_branch_ends_naming_the_singularity() -> None:
    """UR5 (example-robot-data), elbow slightly bent, a LIN straight out from the base: the arm
    stretches until its elbow is straight, a singularity. Refused there, naming it, within 5 mm of where
    Pinocchio's own IK, following the line from the same joints, stops following it."""
    from robwot_bench.reference import example_robot

    r = example_robot("ur5")
    q0 = np.array([0.0, -1.2, 0.4, -0.8, 1.57, 0.0])
    with World() as w:
        m = w.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf)
        w.set_joint_positions(m.id, q0)
        a = np.asarray(w.fk(m.id).position)
        radial = np.array([a[0], a[1], 0.0]) / np.linalg.norm(a[:2])
        plan = plan_lin(w, m.id, tuple(a + 0.3 * radial), None)
    assert not plan.valid
    reason = plan.reasons[0]
    assert "cannot be followed" in reason and "a singularity" in reason, reason
    at = float(reason.split("followed ")[1].split(" mm")[0]) / 1000
    assert at == pytest.approx(_pinocchio_reach_along_line(str(r.urdf), q0, radial, 0.3), abs=0.005)


def test_a_line_a_restart_would_flip_is_followed_on_its_branch() -> None:
    """xArm7 (example-robot-data): a LIN that IK with restarts answered with a 9.4 rad turn of joint1 within
    0.15 mm (refused as a flip) is followed continuously: no joint turns more than 0.1 rad between two
    waypoints, the end effector on the line."""
    from robwot_bench.reference import example_robot

    r = example_robot("xarm7")
    q0 = [2.7610793014764763, -1.9712142421576435, -1.8648914473313412, 1.1582517335361957,
          0.3051068795342573, 1.9601735314249844, 0.34028620651001606]
    target = (0.16353796993173636, 0.5098476784895332, 0.11282432340007374)
    with World() as w:
        m = w.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf)
        w.set_joint_positions(m.id, q0)
        a = np.asarray(w.fk(m.id).position)
        plan = plan_lin(w, m.id, target, None)
        assert plan.valid, plan.reasons
        path = [np.asarray(q0), *map(np.asarray, plan.via), np.asarray(plan.target)]
        assert max(float(np.abs(qb - qa).max()) for qa, qb in itertools.pairwise(path)) < 0.1
        b = np.asarray(target)
        assert max(distance_to_segment(np.asarray(w.fk(m.id, q).position), a, b) for q in path) < 1e-3


def test_a_refusal_names_the_first_cause_along_the_line() -> None:
    """A post 15 cm along a line that leaves the reach further on: the refusal names the post, the cause
    met first, not the reach."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        a = np.asarray(w.fk(m.id).position)
        w.add_obstacle({"name": "post", "shape": {"type": "box", "size": [0.02, 0.3, 0.3]},
                        "position": list(a + np.array([0.15, 0.0, 0.0]))})
        plan = plan_lin(w, m.id, tuple(a + np.array([2.0, 0.0, 0.0])), None)
        assert not plan.valid
        assert plan.reasons[0].startswith("LIN refused: the line collides (") and "post" in plan.reasons[0]
