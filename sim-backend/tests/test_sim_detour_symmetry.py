"""A move back along a path the planner just found is never refused (issue 26), on arms as published for
ROS (example-robot-data Z1 and xArm7) among boxes, from a home pose that lies within the robot's
clearance of an obstacle without touching it (there the way back used to be refused every time)."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np
import pytest

from robwot_bench.reference import example_robot
from robwot_sim.sim import detour
from robwot_sim.sim.planner import Plan, plan_joints
from robwot_sim.sim.timed import Curve, Straight
from robwot_sim.sim.trajectory import turning
from robwot_sim.sim.world import World

DT = 1 / 60
BOXES = [("table", [1.4, 1.4, 0.02], [0.0, 0.0, -0.03]),
         ("pillar", [0.08, 0.08, 0.6], [0.35, 0.0, 0.3]),
         ("wall", [0.3, 0.05, 0.3], [0.0, 0.35, 0.3])]
#: detours planned from home per robot (each then walked back)
DETOURS = 4


@pytest.fixture(scope="module", params=["z1", "xarm7"])
def arm(request: pytest.FixtureRequest) -> Iterator[tuple[World, str, np.ndarray, list[np.ndarray]]]:
    """The arm among the boxes, a home within its clearance of a box, and targets reached from home by a
    detour only (the straight path collides, the target itself is free)."""
    r = example_robot(request.param)
    rng = np.random.default_rng(1)
    with World() as world:
        model = world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf)
        rid = model.id
        for name, size, pos in BOXES:
            world.add_obstacle({"name": name, "shape": {"type": "box", "size": size}, "position": pos})
        lo, hi = model.limits()
        for _ in range(5000):
            home = rng.uniform(lo, hi) * 0.5
            world.set_joint_positions(rid, home)
            if world.check_collision(rid).collision_free and world.motion_clearance(rid) == 0.0:
                break
        else:
            pytest.fail("no home within the clearance of a box found")
        targets: list[np.ndarray] = []
        while len(targets) < DETOURS:
            t = rng.uniform(lo, hi)
            if world.check_collision(rid, t).collision_free and not world.check_path(rid, t).collision_free:
                targets.append(t)
        yield world, rid, home, targets


def _plan(world: World, rid: str, start: np.ndarray, target: np.ndarray) -> Plan:
    world.set_joint_positions(rid, start)
    return plan_joints(world, rid, target.tolist(), 1.0, DT)


def test_the_way_back_from_every_detour_is_found_by_a_new_search(
        arm: tuple[World, str, np.ndarray, list[np.ndarray]], monkeypatch: pytest.MonkeyPatch) -> None:
    """With no detour remembered, each detour's way back home is found by a search of its own: the path
    check keeps the same clearance both ways (a home within it relaxes the way there and the way back),
    and a segment OMPL took but our check refuses is searched again instead of failing the detour."""
    world, rid, home, targets = arm
    monkeypatch.setattr(detour.DetourMemory, "stretches", lambda *_: [])
    for t in targets:
        there = _plan(world, rid, home, t)
        assert there.valid and there.checks["path"]["planned"] == "detour", there.reasons
        back = _plan(world, rid, np.array(there.target), home)
        assert back.valid, back.reasons
        assert back.checks["path"]["planned"] == "detour"


def test_a_remembered_detour_is_taken_back_reversed_and_again_the_same(
        arm: tuple[World, str, np.ndarray, list[np.ndarray]]) -> None:
    """The way back along a detour just found is that detour reversed (checked again); the same request
    again gets the same detour."""
    world, rid, home, targets = arm
    for t in targets:
        there = _plan(world, rid, home, t)
        assert there.valid and there.checks["path"]["planned"] == "detour", there.reasons
        assert _plan(world, rid, home, t).via == there.via
        back = _plan(world, rid, np.array(there.target), home)
        assert back.valid, back.reasons
        assert [*back.via, back.target] == [*reversed(there.via), tuple(home.tolist())]


def test_a_move_from_a_detours_end_to_one_of_its_waypoints_takes_that_stretch_back(
        arm: tuple[World, str, np.ndarray, list[np.ndarray]]) -> None:
    """From a start that keeps the clearance: a move from a detour's end to one of its waypoints whose
    straight path collides runs back along the detour's stretch between them (the checks it passed
    are the ones it was found with)."""
    world, rid, _, targets = arm
    lo, hi = world.robot_model(rid).limits()
    rng = np.random.default_rng(3)
    stretches = 0
    for attempt in range(40):
        if stretches == 2:
            break
        t, start = targets[attempt % len(targets)], rng.uniform(lo, hi)
        world.set_joint_positions(rid, start)
        if not world.check_collision(rid).collision_free or world.motion_clearance(rid, t) == 0.0:
            continue
        there = _plan(world, rid, start, t)
        if not there.valid or len(there.via) < 3:
            continue
        end = np.array(there.target)
        k = len(there.via) // 2
        if world.check_path(rid, np.array(there.via[k]), start=end).collision_free:
            continue
        part = _plan(world, rid, end, np.array(there.via[k]))
        assert part.valid, part.reasons
        assert [*part.via, part.target] == list(reversed(there.via[k:]))
        stretches += 1
    assert stretches == 2, "too few stretches taken back: the test proves little"


def test_the_straight_path_verdict_does_not_depend_on_its_direction(
        arm: tuple[World, str, np.ndarray, list[np.ndarray]]) -> None:
    """Between home (within the clearance) and free states, and between free states, the straight path
    from a to b collides exactly when the one from b to a does; some of them do."""
    world, rid, home, _ = arm
    model = world.robot_model(rid)
    lo, hi = model.limits()
    rng = np.random.default_rng(7)
    states = [home]
    while len(states) < 12:
        q = rng.uniform(lo, hi)
        if world.check_collision(rid, q).collision_free:
            states.append(q)
    verdicts = []
    for a, b in itertools.pairwise(states):
        for x, y in ((home, b), (a, b)):
            there = world.check_path(rid, y, start=x).collision_free
            assert world.check_path(rid, x, start=y).collision_free == there
            verdicts.append(there)
    assert 0 < sum(verdicts) < len(verdicts)


def test_a_detour_runs_as_one_motion_resting_only_where_its_path_turns(
        arm: tuple[World, str, np.ndarray, list[np.ndarray]]) -> None:
    """A detour's timed path rests nowhere its direction does not turn (it used to stop at every waypoint,
    collinear ones included): one curve whose TOPP-RA speed is above zero at every inner grid point, or,
    where stopping at its few turns is faster, straight pieces one per turn. It takes no longer than its
    waypoints run at rest at each, touches nothing when checked again state by state, and some detours
    run as curves. Run with ``stops`` (as a physical robot runs it relayed leg by leg), the same waypoints
    are straight pieces at rest at each turn, never faster."""
    world, rid, home, targets = arm
    curves = 0
    for t in targets:
        there = _plan(world, rid, home, t)
        assert there.valid and there.path is not None, there.reasons
        corners = turning([home, *map(np.asarray, there.via), np.asarray(there.target)])
        pieces = there.path.pieces
        if isinstance(pieces[0], Curve):
            assert len(pieces) == 1 and pieces[0].speeds[1:-1].min() > 0
            curves += 1
        else:
            assert [type(p) for p in pieces] == [Straight] * (len(corners) - 1)
        legs = world.plan_motion(rid, there.target, home, 1.0, DT, there.via)
        assert there.path.duration <= legs.duration + DT
        assert world.check_states(rid, there.path).collision_free
        world.set_joint_positions(rid, home)
        stops = plan_joints(world, rid, t.tolist(), 1.0, DT, detour="stops")
        assert stops.via == there.via and stops.path is not None  # the remembered detour
        assert [type(p) for p in stops.path.pieces] == [Straight] * (len(corners) - 1)
        assert stops.path.duration >= there.path.duration
    assert curves > 0
