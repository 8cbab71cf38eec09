"""Joint-space motion timing (pure): joint states one per ``dt`` under velocity and acceleration limits.

Two shapes of path, each time-optimal for its limits:

- a straight segment in joint space (PTP, each leg of a detour): rest to rest, all joints moving along
  the line and arriving together, the path parameter on a trapezoidal (or triangular) velocity profile
  whose peak velocity and acceleration are the largest any joint's limits allow. This closed form is the
  exact time-optimal profile of a straight line, so it is written here rather than discretised by a
  path-parametrisation library;
- a curve through dense joint samples (LIN, CIRC): the cubic spline through the samples, timed by TOPP-RA
  (``toppra``, time-optimal path parametrisation) under the joint velocity and acceleration limits and the
  end effector's speed and acceleration along the curve (its arc length is carried as one more coordinate
  of the path with those two limits). At rest at both ends.

The profile's duration is rounded up to whole time steps by slowing the whole profile uniformly, so the
states are exactly ``dt`` apart, the first is the start, the last the target, and no limit is exceeded.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from robwot_sim.errors import InvalidParams
from robwot_sim.limits import ACCELERATION, DT, SPEED, TCP_ACCELERATION, Range
from robwot_sim.sim.types import FloatArray

MAX_STEPS = 2_000_000

__all__ = ["TCP_ACCELERATION", "check_fraction", "check_speed_dt", "plan_curve_path", "plan_joint_path"]


def check_speed_dt(speed: object, dt: object) -> tuple[float, float]:
    """Validate a speed fraction and a time step (s) against the contract's ranges."""
    for name, v, bounds in (("speed", speed, SPEED), ("dt", dt, DT)):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise InvalidParams(f"{name} must be a finite number", param=name, expected="number", got=v)
        if v not in bounds:
            within = f"[{bounds.minimum:g}, {bounds.maximum:g}]"
            raise InvalidParams(f"{name} must be in {within}, got {v}", param=name, expected=within, got=v)
    return float(speed), float(dt)  # type: ignore[arg-type]


def check_fraction(name: str, value: object, bounds: Range = ACCELERATION) -> float:
    """Validate ``value`` (``acceleration`` or ``tcpSpeed``) against its contract range."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InvalidParams(f"{name} must be a finite number", param=name, expected="number", got=value)
    if value not in bounds:
        within = f"[{bounds.minimum:g}, {bounds.maximum:g}]"
        raise InvalidParams(f"{name} must be in {within}, got {value}", param=name, expected=within,
                            got=value)
    return float(value)


def _steps(duration: float, dt: float) -> int:
    steps = math.ceil(duration / dt - 1e-9) if duration > 0 else 0
    if steps > MAX_STEPS:
        raise InvalidParams(
            f"motion needs {steps} steps (> {MAX_STEPS}); use a larger dt or speed",
            param="dt",
            expected=f"<= {MAX_STEPS} steps",
            got=steps,
        )
    return steps


def trapezoid(distance: float, vmax: float, amax: float) -> tuple[float, float]:
    """Duration and cruise velocity of the fastest rest-to-rest motion over ``distance`` with velocity at
    most ``vmax`` and acceleration at most ``amax`` (triangular when ``vmax`` is never reached)."""
    if distance <= 0:
        return 0.0, 0.0
    if vmax * vmax / amax >= distance:  # never reaches vmax: accelerate half way, brake the other half
        peak = math.sqrt(distance * amax)
        return 2.0 * peak / amax, peak
    return distance / vmax + vmax / amax, vmax


def _trapezoid_at(t: FloatArray, distance: float, peak: float, amax: float, duration: float) -> FloatArray:
    """Position along the profile of ``trapezoid`` at times ``t`` (clamped to [0, duration])."""
    t = np.clip(t, 0.0, duration)
    ramp = peak / amax
    rise = 0.5 * amax * np.minimum(t, ramp) ** 2
    cruise = peak * np.clip(t - ramp, 0.0, max(0.0, duration - 2 * ramp))
    tail = np.clip(t - (duration - ramp), 0.0, ramp)
    fall = peak * tail - 0.5 * amax * tail**2
    out: FloatArray = np.minimum(rise + cruise + fall, distance)
    return out


def plan_joint_path(
    start: FloatArray, target: FloatArray, velocity: FloatArray, acceleration: FloatArray, dt: float
) -> FloatArray:
    """States ``[steps + 1, dof]`` from ``start`` to ``target`` (both rows included), one per ``dt`` seconds,
    on the straight line between them, at rest at both ends; no joint exceeds ``velocity`` (rad/s or m/s)
    nor ``acceleration`` (rad/s^2 or m/s^2)."""
    delta = target - start
    moving = np.abs(delta) > 0
    if not moving.any():
        return np.array([start], dtype=np.float64)
    # the path parameter s in [0, 1]: joint i moves |delta_i| * s, so s may go at most velocity_i / |delta_i|
    vmax = float(np.min(velocity[moving] / np.abs(delta[moving])))
    amax = float(np.min(acceleration[moving] / np.abs(delta[moving])))
    duration, peak = trapezoid(1.0, vmax, amax)
    steps = _steps(duration, dt)
    if steps == 0:
        return np.array([start, target], dtype=np.float64)
    # the profile slowed uniformly to fill whole steps: sample it at k * duration / steps
    s = _trapezoid_at(np.arange(steps + 1, dtype=np.float64) * (duration / steps), 1.0, peak, amax, duration)
    path: FloatArray = start[None, :] + s[:, None] * delta[None, :]
    path[-1] = target
    return path


def plan_curve_path(
    points: Sequence[FloatArray],
    arc: Sequence[float],
    velocity: FloatArray,
    acceleration: FloatArray,
    tcp_speed: float | None,
    tcp_acceleration: float,
    dt: float,
) -> FloatArray:
    """States ``[steps + 1, dof]`` one per ``dt`` along the cubic spline through ``points`` (the first is the
    start, the last the target), at rest at both ends, time-optimal (TOPP-RA) under the joint limits and
    the end effector's ``tcp_speed`` (m/s) and ``tcp_acceleration`` (m/s^2) along the curve (None: the joint
    limits only), whose arc length at each point is ``arc`` (metres, from 0, increasing)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint

    toppra.setup_logging("WARNING")
    q = np.asarray(points, dtype=np.float64)
    length = np.asarray(arc, dtype=np.float64)
    # the path parameter: the samples' order, by distance in joint space and along the curve (both may
    # stand still while the other moves: a turn in place, a joint-space wobble)
    gaps = np.linalg.norm(np.diff(q, axis=0), axis=1) + np.abs(np.diff(length))
    keep = np.concatenate([[True], gaps > 0])
    q, length = q[keep], length[keep]
    if len(q) < 2:
        return np.array([q[0]], dtype=np.float64)
    ss = np.concatenate([[0.0], np.cumsum(gaps[gaps > 0])])
    ss /= ss[-1]
    if tcp_speed is None:
        waypoints, vlim, alim = q, velocity, acceleration
    else:
        waypoints = np.hstack([q, length[:, None]])
        vlim = np.hstack([velocity, [tcp_speed]])
        alim = np.hstack([acceleration, [tcp_acceleration]])
    path = toppra.SplineInterpolator(ss, waypoints)
    constraints = [toppra.constraint.JointVelocityConstraint(np.stack([-vlim, vlim], axis=1)),
                   toppra.constraint.JointAccelerationConstraint(np.stack([-alim, alim], axis=1))]
    grid = np.unique(np.concatenate([ss, np.linspace(0.0, 1.0, 2 * len(ss))]))
    algorithm = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid,
                                        parametrizer="ParametrizeConstAccel")
    trajectory = algorithm.compute_trajectory(0.0, 0.0)
    if trajectory is None:
        raise InvalidParams("no time parametrisation of the curve meets the joint limits", param="path")
    duration = float(trajectory.duration)
    steps = max(1, _steps(duration, dt))
    times = np.arange(steps + 1, dtype=np.float64) * (duration / steps)
    states = np.asarray(trajectory(times))[:, : q.shape[1]]
    states[0], states[-1] = q[0], q[-1]
    out: FloatArray = states
    return out
