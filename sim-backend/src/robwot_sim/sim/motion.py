"""Joint-space motion planning (pure): linear interpolation at a fixed time step within velocity limits."""

from __future__ import annotations

import math

import numpy as np

from robwot_sim.errors import InvalidParams
from robwot_sim.limits import DT, SPEED
from robwot_sim.sim.types import FloatArray

MAX_STEPS = 2_000_000


def check_speed_dt(speed: object, dt: object) -> tuple[float, float]:
    """Validate a speed fraction and a time step (s) against the contract's ranges."""
    for name, v, bounds in (("speed", speed, SPEED), ("dt", dt, DT)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InvalidParams(f"{name} must be a finite number", param=name, expected="number", got=v)
        if v not in bounds:
            within = f"[{bounds.minimum:g}, {bounds.maximum:g}]"
            raise InvalidParams(f"{name} must be in {within}, got {v}", param=name, expected=within, got=v)
    return float(speed), float(dt)  # type: ignore[arg-type]


def plan_joint_path(
    start: FloatArray, target: FloatArray, velocity: FloatArray, speed: float, dt: float
) -> FloatArray:
    """States ``[steps + 1, dof]`` from ``start`` to ``target`` (both rows included), one per ``dt`` seconds.

    All joints move linearly and arrive together; the slowest joint moves at its velocity limit
    (rad/s or m/s) times ``speed``, so no joint exceeds ``velocity * speed``. The duration is
    ``steps * dt`` (rounded up to whole steps).
    """
    delta = target - start
    duration = float(np.max(np.abs(delta) / (velocity * speed))) if len(delta) else 0.0
    steps = math.ceil(duration / dt - 1e-9) if duration > 0 else 0
    if steps > MAX_STEPS:
        raise InvalidParams(
            f"motion needs {steps} steps (> {MAX_STEPS}); use a larger dt or speed",
            param="dt",
            expected=f"<= {MAX_STEPS} steps",
            got=steps,
        )
    if steps == 0:
        return np.array([start], dtype=np.float64)
    s = np.arange(steps + 1, dtype=np.float64) / steps
    path: FloatArray = start[None, :] + s[:, None] * delta[None, :]
    path[-1] = target
    return path
