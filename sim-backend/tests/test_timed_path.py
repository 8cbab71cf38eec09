"""Timed paths computed on demand (``sim/timed.py``), their geometric check (``pathcheck.py``) and the plan
budget (``world_thread.py``): a path's states are the same however they are asked for; a curve is checked
at points spaced by the robot's travel, as many for a slow motion as for a fast one, and a slow curve
checked that way never lets a contact through (every state of it checked densely by Bullet itself); a
plan running past its budget is refused naming the program's step while the world's thread keeps
serving."""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import pytest
from simhelp import KUKA, steps_of

from robwot_sim.errors import PlanBudget
from robwot_sim.sim.collision import CollisionChecker
from robwot_sim.sim.pathcheck import curve_checkpoints
from robwot_sim.sim.planner import plan_joints, plan_lin
from robwot_sim.sim.program import plan_program
from robwot_sim.sim.timed import Curve, TimedPath
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind, WorldThread, checkpoint

START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]


def _lin(world: World, rid: str, dy: float, *, speed: float,
         tcp_speed: float) -> tuple[Any, TimedPath | None]:
    """A LIN of the KUKA's end effector ``dy`` m along y from START, planned and timed (and checked)."""
    world.set_joint_positions(rid, START)
    x, y, z = world.fk(rid).position
    plan = plan_lin(world, rid, [x, y + dy, z], None, speed=speed, dt=1 / 240, tcp_speed=tcp_speed)
    assert plan.valid, plan.reasons
    return plan, plan.path


def _touching(world: World, rid: str, states: np.ndarray) -> bool:
    """Whether the robot touches anything (Bullet's distance queries, no clearance) at any of ``states``."""
    e = world.scene.entry(rid)
    saved = e.bound.q.copy()
    try:
        for q in states:
            e.bound.apply(q)
            if not e.checker.is_free(1e-9):
                return True
        return False
    finally:
        e.bound.apply(saved)


def test_states_are_the_same_however_they_are_asked_for() -> None:
    """All at once, a chunk at a time, one by one, every k-th: the same states; a detour's legs and a
    LIN's curve joined share their boundary state; a still path is one state."""
    with World() as w:
        m = w.load_robot(KUKA)
        legs = w.plan_motion(m.id, [1.0, 0.5, 0, 0, 0, 0, 0], via=[[0.5, 0, 0, 0, 0, 0, 0]], speed=0.3)
        _, curve = _lin(w, m.id, 0.15, speed=1.0, tcp_speed=0.25)
        assert curve is not None
        path = TimedPath.join([legs, TimedPath.join([TimedPath([p], legs.dt) for p in curve.pieces])])
        rows = path.rows()
        assert len(rows) == len(legs) + len(curve) - 1 == len(path)
        assert np.array_equal(np.concatenate(list(path.chunks(0, 37))), rows)
        assert np.array_equal(np.stack([path[i] for i in range(len(path))]), rows)
        assert np.array_equal(path.rows(3, None, 7), rows[3::7])
        assert np.array_equal(path[-1], rows[-1]) and np.array_equal(path.last, rows[-1])
        assert path.duration == pytest.approx((len(rows) - 1) / 240)
        still = TimedPath.still(np.array(START), 0.01)
        assert len(still) == 1 and still.duration == 0 and np.array_equal(still.rows(), [START])


def test_a_curves_checkpoints_keep_the_travel_between_them_within_the_sweep() -> None:
    """Between two consecutive checkpoints no point of the robot travels more than the spacing: measured on
    the spline sampled 50 times finer, sum_j reach_j x the variation of joint j stays within it."""
    with World() as w:
        m = w.load_robot(KUKA)
        _, path = _lin(w, m.id, 0.2, speed=1.0, tcp_speed=0.25)
        assert path is not None
        curve = path.pieces[0]
        assert isinstance(curve, Curve)
        reach = w.scene.entry(m.id).guard.reach
        for spacing in (0.004, 0.001):
            params = curve_checkpoints(curve, reach, spacing)
            assert params[0] == 0.0 and params[-1] == 1.0 and np.all(np.diff(params) >= 0)
            fine = np.unique(np.concatenate([params, np.linspace(0, 1, 50 * len(params))]))
            travel = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(curve.states(fine), axis=0)) @ reach)])
            at = np.searchsorted(fine, params)
            assert np.max(np.diff(travel[at])) <= spacing * (1 + 1e-6)
            # and not wastefully close: about total travel / spacing of them
            assert len(params) - 1 <= math.ceil(travel[-1] / spacing) + 1


def test_a_slow_curve_costs_no_more_checks_than_a_fast_one(monkeypatch: pytest.MonkeyPatch) -> None:
    """The same LIN at the contract's slowest speeds has a thousand times the states of the default one,
    yet its check makes no more collision queries than the fast one's does (it is checked at points
    spaced by travel; the fast one's few states are checked as they are)."""
    calls = {"n": 0}
    original = CollisionChecker.is_free

    def counted(self: CollisionChecker, *args: Any, **kwargs: Any) -> bool:
        calls["n"] += 1
        return original(self, *args, **kwargs)

    monkeypatch.setattr(CollisionChecker, "is_free", counted)
    with World() as w:
        m = w.load_robot(KUKA)
        queries, lengths = [], []
        for speed, tcp in ((1.0, 0.25), (0.001, 0.001)):
            _, path = _lin(w, m.id, 0.15, speed=speed, tcp_speed=tcp)
            assert path is not None
            calls["n"] = 0
            assert w.check_states(m.id, path).collision_free
            queries.append(calls["n"])
            lengths.append(len(path))
    assert lengths[1] > 100 * lengths[0]
    assert queries[1] <= 1.5 * queries[0], queries


def test_a_slow_curve_checked_at_its_checkpoints_lets_no_contact_through() -> None:
    """A slow CIRC (a half circle of 10 cm radius: its joint path bends), timed (its states closer
    together than the clearance: checked at points spaced by travel), then boxes placed at random near its
    arc: whenever the check passes the path, every state of the run and the moves between them
    (subdivided to 1 mm of joint travel) are free of contact for Bullet itself; some placements are
    refused, so the boxes do come close."""
    rng = np.random.default_rng(34)
    passed = refused = 0
    with World() as w:
        m = w.load_robot(KUKA)
        guard = w.scene.entry(m.id).guard
        w.set_joint_positions(m.id, START)
        x, y, z = w.fk(m.id).position
        arc = plan_lin(w, m.id, [x, y + 0.2, z], None, [x, y + 0.1, z + 0.1], speed=0.2, dt=1 / 240,
                       tcp_speed=0.03)
        assert arc.valid, arc.reasons
        path = arc.path
        assert path is not None
        curve = path.pieces[0]
        assert isinstance(curve, Curve) and curve.row_travel_bound(guard.reach) <= guard.clearance
        rows = path.rows()
        steps = np.ceil(np.max(np.abs(np.diff(rows, axis=0)), axis=1) / 0.001).astype(int)
        dense = np.concatenate([rows[:1], *(a + np.arange(1, n + 1)[:, None] / n * (b - a)
                                            for a, b, n in zip(rows[:-1], rows[1:], steps, strict=True))])
        tcp = np.array([w.fk(m.id, q).position for q in rows[::40]])
        for _ in range(150):
            centre = tcp[rng.integers(len(tcp))] + rng.uniform(-0.15, 0.15, 3)
            w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [0.02, 0.02, 0.02]},
                            "position": centre.tolist()})
            if _touching(w, m.id, rows[:1]):
                # a start in contact may be left while the contact recedes: test_sim_exit_contact.py
                w.remove_obstacle("box")
                continue
            if w.check_states(m.id, path).collision_free:
                assert not _touching(w, m.id, dense), f"a contact passed, box at {centre}"
                passed += 1
            else:
                refused += 1
            w.remove_obstacle("box")
    assert passed >= 3 and refused >= 3, (passed, refused)


def test_a_plan_past_its_budget_is_refused_naming_the_step_and_the_thread_serves_on() -> None:
    """A program of LIN steps given a budget far too small: `PlanBudget` with the budget, the step it was
    planning and the number of steps; short jobs queued meanwhile were served, and the world's thread
    serves the next job at once. A long job without a budget is never refused by time."""
    world, owner = World(), WorldThread()
    try:
        owner.call(world.bind)
        rid = owner.call(lambda: world.load_robot(KUKA).id)
        owner.call(lambda: world.set_joint_positions(rid, START))
        x, y, z = owner.call(lambda: world.fk(rid).position)
        # LINs back and forth: each one's samples are IK solutions (tens of milliseconds of work)
        lins = [{"motion": "lin", "position": [x, y - (0.0 if k % 2 else 0.2), z]} for k in range(60)]
        steps = steps_of(lins, 7)
        job = owner.submit(lambda: plan_program(world, rid, steps, 1 / 240, 50.0), Kind.LONG, robot=rid,
                           budget=0.3)
        time.sleep(0.1)
        t = time.monotonic()
        assert owner.submit(lambda: world.get_joint_positions(rid).tolist(), Kind.SHORT,
                            robot=rid).future.result(5) == pytest.approx(START)
        assert time.monotonic() - t < 0.25
        with pytest.raises(PlanBudget) as refused:
            job.future.result(30)
        data = refused.value.data
        assert data["budget"] == 0.3 and data["steps"] == 60 and 0 < data["step"] < 60
        assert f"step {data['step']} of 60" in refused.value.message
        assert owner.call(lambda: world.get_joint_positions(rid).tolist()) == pytest.approx(START)

        def spin() -> int:
            end, n = time.monotonic() + 0.5, 0
            while time.monotonic() < end:
                checkpoint()
                n += 1
            return n

        assert owner.submit(spin, Kind.LONG, robot=rid).future.result(5) > 0
    finally:
        owner.shutdown()
        world.close()


def test_every_valid_plan_carries_the_path_it_checked() -> None:
    """A straight joint plan, a detour and a LIN each carry their timed path, timed as asked (speed, dt,
    acceleration), from the state they were planned in to their target; a refused plan carries none."""
    with World() as w:
        m = w.load_robot(KUKA)
        straight = plan_joints(w, m.id, START, 0.5, 1 / 240)
        slower = plan_joints(w, m.id, START, 0.5, 1 / 240, acceleration=0.25)
        for plan in (straight, slower):
            assert plan.valid and plan.path is not None and plan.path.dt == 1 / 240
            assert plan.path.first == pytest.approx(w.get_joint_positions(m.id))
            assert plan.path.last == pytest.approx(START)
        assert slower.path is not None and straight.path is not None and len(slower.path) > len(straight.path)
        # a box where the end effector passes on the straight way to the target: a detour
        wall = list(w.fk(m.id, [0, 0.6, 0, 0, 0, 0, 0]).position)
        w.add_obstacle({"name": "wall", "shape": {"type": "box", "size": [0.1, 0.4, 0.1]}, "position": wall})
        detour = plan_joints(w, m.id, [0, 1.2, 0, 0, 0, 0, 0], 1.0, 1 / 240)
        assert detour.valid and detour.checks["path"]["planned"] == "detour" and detour.via
        # one motion through its corners when the smoothed curve passes the check, else straight pieces that
        # stop at its via points: both are valid, and which one depends on the detour OMPL finds, which
        # depends on the searches this process ran before (OMPL takes its seed once per process)
        assert detour.path is not None
        kinds = [type(piece).__name__ for piece in detour.path.pieces]
        assert kinds[0] == "Curve" or kinds == ["Straight"] * (len(detour.via) + 1), kinds
        assert w.check_states(m.id, detour.path).collision_free
        assert detour.path.last == pytest.approx([0, 1.2, 0, 0, 0, 0, 0])
        w.remove_obstacle("wall")
        _, lin = _lin(w, m.id, 0.1, speed=1.0, tcp_speed=0.25)
        assert lin is not None and isinstance(lin.pieces[0], Curve)
        refused = plan_joints(w, m.id, [0.0, 3.0, 0, 0, 0, 0, 0], 1.0, 1 / 240)
        assert not refused.valid and refused.path is None
