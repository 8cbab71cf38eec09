"""A program: steps planned one after the other, each from where the previous one ends, by the same
planners as single moves (``planner.py``: PTP with its detours, LIN, CIRC). The robot's true state is
untouched: the steps are planned in ``World.hypothetical`` states.

Each step is timed as a move of the same step is (``planner.timed_path``: the joint velocity limits x its
``speed``, acceleration limits x its ``acceleration``, a LIN's or CIRC's ``tcpSpeed``), at rest where it
ends. The program's path is those states one after the other, one per ``dt``: its cycle time is the time a
run of it takes at real time (``program.run`` runs exactly these states), and the trajectory a client gets
is that path sampled at ``rate``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robwot_sim.limits import DEFAULT_TCP_SPEED
from robwot_sim.sim.planner import Plan, plan_joints, plan_lin, plan_pose, timed_path
from robwot_sim.sim.types import FloatArray
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import checkpoint


@dataclass
class ProgramPlan:
    """The report (``ProgramPlan`` of the contract) and, when every step passes, what a run runs."""

    report: dict[str, Any]
    #: the joint states of the whole program, one per ``dt`` (None when a step is refused)
    path: FloatArray | None = None
    #: index in ``path`` of each step's first state (its start: the previous step's end)
    starts: list[int] = field(default_factory=list)


def _plan_step(world: World, robot: str, step: Mapping[str, Any], dt: float) -> Plan:
    motion, speed = str(step.get("motion", "ptp")), float(step.get("speed", 1.0))
    if step.get("target") is not None:
        return plan_joints(world, robot, [float(v) for v in step["target"]], speed, dt)
    position = [float(v) for v in step["position"]]
    orientation = [float(v) for v in step["orientation"]] if step.get("orientation") is not None else None
    if motion == "ptp":
        return plan_pose(world, robot, position, orientation, speed, dt)
    via = [float(v) for v in step["via"]] if motion == "circ" else None
    return plan_lin(world, robot, position, orientation, via, speed=speed,
                    tcp_speed=float(step.get("tcpSpeed", DEFAULT_TCP_SPEED)))


def plan_program(world: World, robot: str, steps: Sequence[Mapping[str, Any]], dt: float,
                 rate: float) -> ProgramPlan:
    """Per-step verdicts (from the first step to the first refused one), the index of the first refused
    step (None when all pass), the cycle time (s) and the joint trajectory sampled at ``rate`` (Hz)."""
    names = list(world.robot_model(robot).controllable)
    verdicts: list[dict[str, Any]] = []
    first_failing: int | None = None
    segments: list[FloatArray] = []
    starts: list[int] = []
    with world.hypothetical(robot):
        q = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
        done = 0
        for k, step in enumerate(steps):
            checkpoint()
            world.place(robot, q)
            plan, path = timed_path(world, robot, _plan_step(world, robot, step, dt),
                                    speed=float(step.get("speed", 1.0)), dt=dt,
                                    acceleration=float(step.get("acceleration", 1.0)))
            verdict: dict[str, Any] = {"step": k, "ok": plan.valid, "reasons": list(plan.reasons),
                                       "checks": plan.checks, "duration": 0.0}
            verdicts.append(verdict)
            if path is None or plan.target is None:
                first_failing = k
                break
            verdict["duration"] = (len(path) - 1) * dt
            verdict["planned"] = plan.checks.get("path", {}).get("planned", "straight")
            verdict["target"] = list(plan.target)
            starts.append(done)
            segments.append(path if not segments else path[1:])
            done += len(path) - 1
            q = np.asarray(plan.target, dtype=np.float64)
    trajectory = np.concatenate(segments) if segments else np.asarray([world.get_joint_positions(robot)])
    stride = max(1, round(1.0 / (rate * dt)))
    picked = trajectory[::stride]
    if len(trajectory) and not np.array_equal(picked[-1], trajectory[-1]):
        picked = np.vstack([picked, trajectory[-1]])
    cycle = float(sum(v["duration"] for v in verdicts))
    report = {"valid": first_failing is None, "firstFailingStep": first_failing, "cycleTime": cycle,
              "steps": verdicts,
              "trajectory": {"rate": 1.0 / (stride * dt), "dt": stride * dt, "names": names,
                             "positions": [[float(x) for x in row] for row in picked]}}
    if first_failing is not None:
        return ProgramPlan(report)
    return ProgramPlan(report, trajectory, starts)
