"""Trajectory timing (MoveIt's trajectory processing): a joint path through waypoints becomes the timed
path a motion runs, states one per ``dt`` (computed when asked for, ``timed.py``), within the robot's joint
velocity limits x ``speed`` and acceleration limits x ``acceleration`` (``motion.py``).

The planners time the path they check (``planner.py``): a valid plan carries that timed path and a move
runs it, so no path is timed twice.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

from robwot_sim.limits import (
    DEFAULT_ACCELERATION,
    DEFAULT_DT,
    DEFAULT_SPEED,
    DEFAULT_TCP_SPEED,
    TCP_ACCELERATION,
)
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.sim.motion import plan_curve_path, plan_joint_path
from robwot_sim.sim.planning_scene import JointVector, Scene
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.types import FloatArray


def time_path(model: RobotModel, points: Sequence[FloatArray], speed: float, dt: float,
              acceleration: float, arc: Sequence[float] = (),
              tcp_speed: float | None = DEFAULT_TCP_SPEED) -> TimedPath:
    """The timed path through ``points`` (joint states within the limits, the start first), states ``dt``
    (s) apart, within the joint velocity limits x ``speed`` and acceleration limits x ``acceleration``
    (values within the contract's ranges: checked where a request enters). Without ``arc``: each segment
    straight in joint space, at rest at every point. With ``arc`` (the end effector's distance along its
    curve at each point, m): one smooth motion through them, the end effector at most ``tcp_speed`` (m/s;
    None: the joint limits only, a blended group of PTP steps) and ``acceleration`` x its acceleration
    limit."""
    velocity = model.velocity_limits() * speed
    accelerations = model.acceleration_limits() * acceleration
    followers = model.follower_rates().scaled(speed, acceleration)
    if len(arc):
        if len(arc) != len(points):
            raise ValueError(f"arc needs one distance per point: {len(arc)} for {len(points)}")
        curve = plan_curve_path(points, arc, velocity, accelerations, tcp_speed,
                                TCP_ACCELERATION * acceleration, dt, model.limits(), followers)
        return TimedPath([curve], dt)
    pieces = [plan_joint_path(a, b, velocity, accelerations, dt, followers)
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
) -> TimedPath:
    """``time_path`` from ``start`` (default: the current state) through ``via`` to ``target``, each
    checked against the robot's joint limits."""
    e = scene.entry(robot_id)
    tgt = e.bound.validate(target, "target")
    st = e.bound.q.copy() if start is None else e.bound.validate(start, "from")
    points = [st, *(e.bound.validate(w, f"via[{i}]") for i, w in enumerate(via)), tgt]
    return time_path(e.model, points, speed, dt, acceleration, arc, tcp_speed)
