"""A program: steps planned one after the other, each from where the previous one ends, by the same
planners as single moves (``planner.py``: PTP with its detours, LIN, CIRC). The robot's true state is
untouched: the steps are planned in ``World.hypothetical`` states. Each step's duration is that of the
joint path a move runs (``World.plan_motion`` at the step's speed and ``dt``), so the cycle time is the
sum a run of the same steps takes at real time; the joint trajectory is sampled from those paths.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from robwot_sim.sim.planner import Plan, plan_joints, plan_lin, plan_pose
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import checkpoint


def _plan_step(world: World, robot: str, step: Mapping[str, Any], dt: float) -> Plan:
    motion, speed = str(step.get("motion", "ptp")), float(step.get("speed", 1.0))
    if step.get("target") is not None:
        return plan_joints(world, robot, [float(v) for v in step["target"]], speed, dt)
    position = [float(v) for v in step["position"]]
    orientation = [float(v) for v in step["orientation"]] if step.get("orientation") is not None else None
    if motion == "ptp":
        return plan_pose(world, robot, position, orientation, speed, dt)
    via = [float(v) for v in step["via"]] if motion == "circ" else None
    return plan_lin(world, robot, position, orientation, via)


def plan_program(world: World, robot: str, steps: Sequence[Mapping[str, Any]], dt: float,
                 rate: float) -> dict[str, Any]:
    """Per-step verdicts (from the first step to the first refused one), the index of the first refused
    step (None when all pass), the cycle time (s) and the joint trajectory sampled at ``rate`` (Hz)."""
    names = list(world.robot_model(robot).controllable)
    verdicts: list[dict[str, Any]] = []
    first_failing: int | None = None
    samples: list[np.ndarray] = []
    with world.hypothetical(robot):
        q = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
        for k, step in enumerate(steps):
            checkpoint()
            world.place(robot, q)
            plan = _plan_step(world, robot, step, dt)
            verdict: dict[str, Any] = {"step": k, "ok": plan.valid, "reasons": list(plan.reasons),
                                       "checks": plan.checks, "duration": 0.0}
            if not plan.valid or plan.target is None:
                verdicts.append(verdict)
                first_failing = k
                break
            path = world.plan_motion(robot, plan.target, start=q, speed=float(step.get("speed", 1.0)), dt=dt,
                                     via=plan.via)
            verdict["duration"] = (len(path) - 1) * dt
            verdict["planned"] = plan.checks.get("path", {}).get("planned", "straight")
            verdict["target"] = list(plan.target)
            verdicts.append(verdict)
            samples.append(path if not samples else path[1:])
            q = np.asarray(plan.target, dtype=np.float64)
    trajectory = np.concatenate(samples) if samples else np.asarray([world.get_joint_positions(robot)])
    stride = max(1, round(1.0 / (rate * dt)))
    picked = trajectory[::stride]
    if len(trajectory) and not np.array_equal(picked[-1], trajectory[-1]):
        picked = np.vstack([picked, trajectory[-1]])
    cycle = float(sum(v["duration"] for v in verdicts))
    return {"valid": first_failing is None, "firstFailingStep": first_failing, "cycleTime": cycle,
            "steps": verdicts,
            "trajectory": {"rate": 1.0 / (stride * dt), "dt": stride * dt, "names": names,
                           "positions": [[float(x) for x in row] for row in picked]}}
