"""Trajectory timing (MoveIt's trajectory processing): a joint path through waypoints becomes the timed
path a motion runs, states one per ``dt`` (computed when asked for, ``timed.py``), within the robot's joint
velocity limits x ``speed`` and acceleration limits x ``acceleration`` (``motion.py``).

The planners time the path they check (``planner.py``): a valid plan carries that timed path and a move
runs it, so no path is timed twice.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robwot_sim.limits import (
    DEFAULT_ACCELERATION,
    DEFAULT_DT,
    DEFAULT_SPEED,
    DEFAULT_TCP_SPEED,
    TCP_ACCELERATION,
)
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.sim.motion import (
    CurveLimits,
    jerk_limited_curve,
    plan_curve_path,
    plan_joint_path,
)
from robwot_sim.sim.planning_scene import JointVector, Scene
from robwot_sim.sim.timed import Curve, TimedPath
from robwot_sim.sim.types import FloatArray

#: radians a joint may turn between two points of a straight joint-space stretch a curve is timed along
#: (the spline through them: dense points keep it on the straight line, rounding only its corners)
CURVE_POINT_STEP = 0.02
#: radians the direction of a joint-space path may turn at a point for the point to be on a straight line
STRAIGHT_ANGLE = 1e-3


def densified(corners: Sequence[FloatArray], step: float = CURVE_POINT_STEP) -> list[FloatArray]:
    """The polyline through ``corners`` as points, each segment split so no joint turns more than ``step``
    between two of them."""
    out = [np.asarray(corners[0], dtype=np.float64)]
    for a, b in itertools.pairwise(np.asarray(c, dtype=np.float64) for c in corners):
        n = max(1, math.ceil(float(np.max(np.abs(b - a))) / step))
        out.extend(a + k / n * (b - a) for k in range(1, n + 1))
    return out


def turning(corners: Sequence[FloatArray], angle: float = STRAIGHT_ANGLE) -> list[FloatArray]:
    """``corners`` without the points where the path does not turn (by less than ``angle`` rad in joint
    space, or standing still): a motion at rest at each point then rests only at real corners."""
    out = [np.asarray(corners[0], dtype=np.float64)]
    for q, nxt in itertools.pairwise(np.asarray(c, dtype=np.float64) for c in corners[1:]):
        d0, d1 = q - out[-1], nxt - q
        n0, n1 = float(np.linalg.norm(d0)), float(np.linalg.norm(d1))
        if n0 == 0 or n1 == 0:
            continue
        if math.acos(min(1.0, max(-1.0, float(d0 @ d1) / (n0 * n1)))) >= angle:
            out.append(q)
    out.append(np.asarray(corners[-1], dtype=np.float64))
    return out


@dataclass(frozen=True)
class Along:
    """Limits that change along a curve, one value per point: the joint limits x ``speed`` and x
    ``acceleration``, the end effector at most ``tcp_speed`` (m/s; None: not limited there) with its
    acceleration limit x ``acceleration`` (a blended chain of steps, each at its own limits)."""

    speed: Sequence[float]
    acceleration: Sequence[float]
    tcp_speed: Sequence[float | None]

    @classmethod
    def constant(cls, n: int, speed: float, acceleration: float, tcp_speed: float | None) -> Along:
        return cls([speed] * n, [acceleration] * n, [tcp_speed] * n)


def curve_limits(model: RobotModel, along: Along) -> CurveLimits:
    """The limits of each point of a curve of ``model``'s joints, scaled as ``along`` says."""
    speed = np.asarray(along.speed, dtype=np.float64)[:, None]
    acc = np.asarray(along.acceleration, dtype=np.float64)[:, None]
    tcp = np.array([math.inf if v is None else v for v in along.tcp_speed], dtype=np.float64)
    followers = model.follower_rates()
    return CurveLimits(
        velocity=model.velocity_limits()[None, :] * speed,
        acceleration=model.acceleration_limits()[None, :] * acc,
        tcp_speed=tcp, tcp_acceleration=np.where(np.isfinite(tcp), TCP_ACCELERATION * acc[:, 0], math.inf),
        rows=followers.rows, follower_velocity=followers.velocity[None, :] * speed,
        follower_acceleration=followers.acceleration[None, :] * acc)


def time_path(model: RobotModel, points: Sequence[FloatArray], speed: float, dt: float,
              acceleration: float, arc: Sequence[float] = (),
              tcp_speed: float | None = DEFAULT_TCP_SPEED, along: Along | None = None,
              tcp: Sequence[Sequence[float]] | None = None) -> TimedPath:
    """The timed path through ``points`` (joint states within the limits, the start first), states ``dt``
    (s) apart, within the joint velocity limits x ``speed`` and acceleration limits x ``acceleration``
    (values within the contract's ranges: checked where a request enters). Without ``arc``: each segment
    straight in joint space, at rest at every point. With ``arc`` (the end effector's distance along its
    curve at each point, m): one smooth motion through them, the end effector at most ``tcp_speed`` (m/s;
    None: the joint limits only) and ``acceleration`` x its acceleration limit (the total: tangential and
    centripetal), its position at each point ``tcp``; ``along``, when given, replaces the three by
    limits per point."""
    if len(arc):
        if len(arc) != len(points):
            raise ValueError(f"arc needs one distance per point: {len(arc)} for {len(points)}")
        along = along or Along.constant(len(points), speed, acceleration, tcp_speed)
        if len(along.speed) != len(points):
            raise ValueError(f"along needs limits per point: {len(along.speed)} for {len(points)}")
        limits = curve_limits(model, along)
        curve = plan_curve_path(points, arc, limits, dt, model.limits(), tcp)
        if isinstance(curve, Curve) and model.jerks:
            fastest = np.max(limits.velocity, axis=0), np.max(limits.acceleration, axis=0)
            curve = jerk_limited_curve(curve, model.jerk_limits() * min(along.acceleration), *fastest, dt)
        return TimedPath([curve], dt)
    velocity = model.velocity_limits() * speed
    accelerations = model.acceleration_limits() * acceleration
    followers = model.follower_rates().scaled(speed, acceleration)
    jerk = model.jerk_limits() * acceleration
    pieces = [plan_joint_path(a, b, velocity, accelerations, dt, followers, jerk)
              for a, b in itertools.pairwise(points)]
    return TimedPath(pieces, dt)


def plan_motion(
    scene: Scene,
    robot_id: str,
    target: JointVector,
    start: JointVector | None = None,
    speed: float = DEFAULT_SPEED,
    dt: float = DEFAULT_DT,
    via: Sequence[JointVector] = (),
    *,
    acceleration: float = DEFAULT_ACCELERATION,
    arc: Sequence[float] = (),
    tcp_speed: float | None = DEFAULT_TCP_SPEED,
    along: Along | None = None,
    tcp: Sequence[Sequence[float]] | None = None,
) -> TimedPath:
    """``time_path`` from ``start`` (default: the current state) through ``via`` to ``target``, each
    checked against the robot's joint limits; the end effector's positions ``tcp`` (one per point) by FK
    unless the caller has them."""
    e = scene.entry(robot_id)
    tgt = e.bound.validate(target, "target")
    st = e.bound.q.copy() if start is None else e.bound.validate(start, "from")
    points = [st, *(e.bound.validate(w, f"via[{i}]") for i, w in enumerate(via)), tgt]
    limited = tcp_speed is not None if along is None else any(v is not None for v in along.tcp_speed)
    if tcp is None and len(arc) and limited:
        tcp = [scene.fk(robot_id, p).position for p in points]
    return time_path(e.model, points, speed, dt, acceleration, arc, tcp_speed, along, tcp)
