"""Jerk limits on the random programs (``program_random.py``, issue 38): each arm loaded again with every
joint's jerk limited to each of ``JERK_FACTORS`` x its acceleration limit (robot.load ``jerkLimits``; a
Franka Panda's published limits are about 500 x), among the same
obstacles, the same valid programs planned again from the same starts. Per program: the largest joint jerk
of the full-rate trajectory (third differences of its states, independent of how the planner limits it)
against its limit, and the cycle time against the acceleration-limited one (what jerk limits cost). A
detour is searched anew in the second backend, so a program with one compares two paths: its cost is
listed apart."""

from __future__ import annotations

import shutil
import statistics
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from robwot_bench.program import Backend
from robwot_sim.limits import ACCELERATION_TIME, DEFAULT_DT

if TYPE_CHECKING:
    from robwot_bench.program_random import F

#: jerk limits per joint in multiples of its acceleration limit (1/s): the acceleration reached in 10 ms,
#: and in 0.1 s
JERK_FACTORS = (100.0, 10.0)


@dataclass
class JerkResult:
    name: str
    factor: float
    refused: int = 0
    #: per program: largest jerk / its limit over the joints
    peaks: list[float] = field(default_factory=list)
    #: per program without a detour, and with one: jerk-limited cycle / acceleration-limited cycle
    costs: list[float] = field(default_factory=list)
    detour_costs: list[float] = field(default_factory=list)


def jerk_arm(name: str, kept: list[tuple[F, list[dict[str, Any]], float]], factor: float,
             log: Callable[[str], None]) -> JerkResult:
    """The programs ``kept`` (start, steps, acceleration-limited cycle) planned with jerk limits of
    ``factor`` x each joint's acceleration limit."""
    from robwot_bench.program_random import OBSTACLES, load_arm

    b = Backend()
    res = JerkResult(name, factor)
    arm = None
    try:
        arm = load_arm(b, name, factor)
        limit = factor * arm.lim.vmax / ACCELERATION_TIME
        for obs, size, pos in OBSTACLES:
            b.call("obstacle.add", {"name": obs, "shape": {"type": "box", "size": list(size)},
                                    "position": list(pos)})
        for i, (q0, steps, cycle) in enumerate(kept):
            b.call("robot.setJointPositions", {"robot": arm.rid, "positions": [float(v) for v in q0]})
            plan = b.call("program.plan", {"robot": arm.rid, "steps": steps, "rate": 1 / DEFAULT_DT})
            if not plan["valid"]:
                res.refused += 1
                log(f"{name} program {i} with jerk limits: refused ({plan['steps'][-1]['reasons']})")
                continue
            h = float(plan["trajectory"]["dt"])
            q = np.asarray(plan["trajectory"]["positions"], dtype=np.float64)
            jerk = np.abs(np.diff(q, 3, axis=0)).max(axis=0) / h**3 if len(q) > 3 else np.zeros(len(limit))
            res.peaks.append(float(np.max(jerk / limit)))
            detour = any(s.get("planned") == "detour" for s in plan["steps"])
            (res.detour_costs if detour else res.costs).append(float(plan["cycleTime"]) / cycle)
    finally:
        b.close()
        if arm is not None:
            shutil.rmtree(arm.tmp, ignore_errors=True)
    return res


def report(results: list[JerkResult]) -> None:
    print("\njerk limits (a factor x each joint's acceleration limit, per s): the same programs again")
    print("| arm | jerk factor | programs | refused | largest jerk / limit "
          "| cycle / acceleration-limited, median (max) | with a detour, median (max) |")
    print("|---|---|---|---|---|---|---|")

    def spread(xs: list[float]) -> str:
        return f"{statistics.median(xs):.3f} ({max(xs):.3f})" if xs else "-"

    for r in results:
        peak = f"{max(r.peaks):.3f}" if r.peaks else "-"
        print(f"| {r.name} | {r.factor:g} | {len(r.peaks) + r.refused} | {r.refused} | {peak} "
              f"| {spread(r.costs)} | {spread(r.detour_costs)} |")
