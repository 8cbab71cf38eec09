"""The motion runner (``motion_runner.py``) with the world called in place of its thread: a move runs the
timed path its plan carries, state for state, and nothing times a path again; a refused plan moves
nothing."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np
import pytest
from simhelp import KUKA, steps_of

from robwot_sim.errors import Rejected
from robwot_sim.motion_runner import MotionRunner
from robwot_sim.sim import trajectory
from robwot_sim.sim.planner import Plan, plan_joints, plan_lin
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind

T = TypeVar("T")
START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]


async def _in_place(fn: Callable[[], T], kind: Kind = Kind.SHORT, **_: Any) -> T:
    """`Services.on_world` without a thread: the function runs at once."""
    return fn()


def _run(world: World, robot: str, plan: Plan) -> tuple[dict[str, Any], list[list[float]]]:
    """A move of ``plan`` as fast as it goes: its result and the positions of every ``robot.state``."""
    sent: list[tuple[str, dict[str, Any]]] = []
    runner = MotionRunner(world, lambda method, params: sent.append((method, params)), _in_place)
    result = asyncio.run(runner.move(robot, lambda: plan, realtime=0))
    return result, [p["positions"] for method, p in sent if method == "robot.state"]


def _never_timed(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*_: Any, **__: Any) -> Any:
        raise AssertionError("a path was timed again")

    monkeypatch.setattr(trajectory, "time_path", refuse)


@pytest.mark.parametrize("motion", ["ptp", "lin"])
def test_a_move_runs_the_path_its_plan_carries_and_times_nothing_again(
        motion: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """A joint plan's straight path and a LIN's curve: every state the run streams is a state of the
    plan's timed path, the run ends at its last state after its duration, and no path is timed during
    the move."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        if motion == "ptp":
            plan = plan_joints(w, m.id, [0.3, 0.2, 0.0, -0.8, 0.0, 0.4, 0.0], 1.0, 1 / 60)
        else:
            x, y, z = w.fk(m.id).position
            plan = plan_lin(w, m.id, [x, y + 0.1, z], None, dt=1 / 60)
        assert plan.valid and plan.path is not None
        rows = plan.path.rows()
        _never_timed(monkeypatch)
        result, streamed = _run(w, m.id, plan)
        assert result["status"] == "reached" and result["positions"] == pytest.approx(rows[-1].tolist())
        assert result["duration"] == pytest.approx(plan.path.duration)
        assert len(streamed) >= 2
        for q in streamed:
            assert np.min(np.max(np.abs(rows - np.asarray(q)), axis=1)) < 1e-12
        assert w.get_joint_positions(m.id) == pytest.approx(rows[-1])


def test_a_refused_plan_moves_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """A plan that is not valid is `Rejected` with its reasons and checks; the robot stays where it was."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        plan = plan_joints(w, m.id, [0.0, 3.0, 0, 0, 0, 0, 0], 1.0, 1 / 240)
        assert not plan.valid and plan.path is None
        with pytest.raises(Rejected) as refused:
            _run(w, m.id, plan)
        assert refused.value.data["reasons"] == list(plan.reasons)
        assert w.get_joint_positions(m.id) == pytest.approx(START)


def test_a_program_runs_the_states_it_planned() -> None:
    """`program.run`'s states are the program plan's: the run ends at the last step's target after the
    plan's cycle time, each streamed state naming its step."""
    with World() as w:
        m = w.load_robot(KUKA)
        steps = steps_of([{"target": START}, {"target": [0.3, 0.2, 0.0, -0.8, 0.0, 0.4, 0.0], "speed": 0.5}],
                         m.dof)
        sent: list[tuple[str, dict[str, Any]]] = []
        runner = MotionRunner(w, lambda method, params: sent.append((method, params)), _in_place)
        result = asyncio.run(runner.run_program(m.id, steps, realtime=0, dt=1 / 60))
        report = result["program"]
        assert result["status"] == "reached" and report["valid"]
        assert result["duration"] == pytest.approx(report["cycleTime"])
        assert result["positions"] == pytest.approx(report["steps"][1]["target"])
        named = [p["step"] for method, p in sent if method == "robot.state"]
        assert named[0] == 0 and named[-1] == 1 and named == sorted(named)


def test_a_run_behind_its_clock_catches_up_checking_every_state() -> None:
    """A world whose every job takes three states' time (a loaded machine), on a fake clock: the run takes
    the states due in one job each time it is behind, so it needs far fewer jobs than states and ends when
    its simulated duration has passed, not three times later; every state is still set (and checked, the
    world having changed: its stamp is not the plan's)."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, START)
        plan = plan_joints(w, m.id, [0.3, 0.2, 0.0, -0.8, 0.0, 0.4, 0.0], 0.05, 1 / 240)
        assert plan.valid and plan.path is not None
        dt, states = plan.path.dt, len(plan.path) - 1
        assert states > 150
        w.add_obstacle({"name": "far", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
                        "position": [3.0, 3.0, 0.0]})  # the world changed since the plan: every state checked
        late = {"by": 0.0, "jobs": 0, "set": 0}
        setter = w.set_joint_positions

        def counted(robot: str, q: Any) -> None:
            late["set"] += 1
            setter(robot, q)

        w.set_joint_positions = counted  # type: ignore[method-assign]

        async def slow(fn: Callable[[], T], kind: Kind = Kind.SHORT, **_: Any) -> T:
            late["jobs"] += 1
            late["by"] += 3 * dt  # the job took three states' time
            return fn()

        async def go() -> tuple[dict[str, Any], float]:
            loop = asyncio.get_running_loop()
            real = loop.time
            loop.time = lambda: real() + late["by"]  # type: ignore[method-assign]
            runner = MotionRunner(w, lambda *_: None, slow)
            t0 = loop.time()
            result = await runner.move(m.id, lambda: plan, realtime=1.0)
            return result, loop.time() - t0

        result, elapsed = asyncio.run(go())
        assert result["status"] == "reached" and result["duration"] == pytest.approx(plan.path.duration)
        assert late["set"] >= states  # every state set
        assert late["jobs"] < states / 2
        assert elapsed < 1.5 * plan.path.duration + 40 * 3 * dt  # not three times the duration
