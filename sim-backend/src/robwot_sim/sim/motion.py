"""Joint-space motion timing (pure): when a path's states are, under velocity and acceleration limits.

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
The result is a piece of a `timed.TimedPath`: its states are computed when asked for, so timing a path
costs the same whatever its duration (a slow motion at a small ``dt`` has millions of states).
"""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams
from robwot_sim.model.robot_model import Rates
from robwot_sim.sim.timed import Curve, Straight
from robwot_sim.sim.types import FloatArray

#: a limit standing for none (m/s, m/s^2, rad/s, ...): far beyond any robot's, finite for toppra
UNLIMITED = 1e9
#: samples of a curve beyond which TOPP-RA's grid is its samples alone
DENSE = 120
#: directions (one of each opposite pair) along which the end effector's acceleration is limited: its
#: total acceleration is within the limit when its component along each is within the limit x
#: ``tcp_cover()`` (``CurveLimits``)
TCP_DIRECTIONS = 50


@functools.cache
def tcp_directions() -> tuple[FloatArray, float]:
    """``TCP_DIRECTIONS`` unit vectors spread over a hemisphere (a Fibonacci spiral) and the cosine of the
    largest angle between any direction and the nearest of them or their opposites, less a degree (the
    angle is measured on 20,000 directions; the margin covers those between them). A vector whose
    component along every one (and opposite) is at most ``c`` x that cosine has a length of at most ``c``."""
    i = np.arange(TCP_DIRECTIONS) + 0.5
    z = 1.0 - i / TCP_DIRECTIONS
    r, turn = np.sqrt(1.0 - z * z), math.pi * (1.0 + math.sqrt(5.0)) * i
    half = np.stack([r * np.cos(turn), r * np.sin(turn), z], axis=1)
    k = np.arange(20_000) + 0.5
    polar, around = np.arccos(1.0 - 2.0 * k / len(k)), math.pi * (1.0 + math.sqrt(5.0)) * k
    probe = np.stack([np.cos(around) * np.sin(polar), np.sin(around) * np.sin(polar), np.cos(polar)], axis=1)
    widest = float(np.arccos(np.clip(np.abs(probe @ half.T).max(axis=1).min(), -1.0, 1.0)))
    return half, math.cos(widest + math.radians(1.0))


def _steps(duration: float, dt: float) -> int:
    """Whole time steps of at most ``dt`` covering ``duration`` (however many: states are computed lazily)."""
    return math.ceil(duration / dt - 1e-9) if duration > 0 else 0


def trapezoid(distance: float, vmax: float, amax: float) -> tuple[float, float]:
    """Duration and cruise velocity of the fastest rest-to-rest motion over ``distance`` with velocity at
    most ``vmax`` and acceleration at most ``amax`` (triangular when ``vmax`` is never reached)."""
    if distance <= 0:
        return 0.0, 0.0
    if vmax * vmax / amax >= distance:  # never reaches vmax: accelerate half way, brake the other half
        peak = math.sqrt(distance * amax)
        return 2.0 * peak / amax, peak
    return distance / vmax + vmax / amax, vmax


def plan_joint_path(
    start: FloatArray, target: FloatArray, velocity: FloatArray, acceleration: FloatArray, dt: float,
    followers: Rates | None = None, jerk: FloatArray | None = None,
) -> Straight:
    """The timed straight line from ``start`` to ``target``: states one per ``dt`` (both ends included),
    at rest at both ends; no joint exceeds ``velocity`` (rad/s or m/s) nor ``acceleration`` (rad/s^2 or
    m/s^2), nor any of ``followers`` its limits, nor ``jerk`` (rad/s^3 or m/s^3, inf: none) when given
    (``_jerk_limited_line``)."""
    delta = target - start
    rates, accels = velocity, acceleration
    if followers is not None and len(followers.rows):
        delta_f = followers.rows @ delta  # a follower moves its row times the joints' motion
        delta, rates = np.concatenate([delta, delta_f]), np.concatenate([velocity, followers.velocity])
        accels = np.concatenate([acceleration, followers.acceleration])
    moving = np.abs(delta) > 0
    if not moving.any():
        return Straight(start, start, 0.0, 0.0, 1.0, 0)
    # the path parameter s in [0, 1]: joint i moves |delta_i| * s, so s may go at most velocity_i / |delta_i|
    vmax = float(np.min(rates[moving] / np.abs(delta[moving])))
    amax = float(np.min(accels[moving] / np.abs(delta[moving])))
    limited = np.isfinite(jerk) & moving[: len(start)] if jerk is not None else np.zeros(len(start), bool)
    if limited.any():
        assert jerk is not None
        per_fraction = float(np.min(jerk[limited] / np.abs(delta[: len(start)][limited])))
        return _jerk_limited_line(vmax, amax, per_fraction, dt, start, target)
    duration, peak = trapezoid(1.0, vmax, amax)
    # the profile slowed uniformly to fill whole steps: state k is the profile at k * duration / steps
    return Straight(start, target, duration, peak, amax, max(1, _steps(duration, dt)))


@dataclass(frozen=True)
class CurveLimits:
    """The limits a curve is timed under, one row per point of it (they may change along the curve: a
    blended chain keeps each step's own): the joints' ``velocity`` and ``acceleration`` (n, dof); the
    limited followers (``rows`` over the joint vector, their ``follower_velocity`` and
    ``follower_acceleration``, (n, f)); the end effector's speed ``tcp_speed`` (m/s) along the curve and
    its total acceleration ``tcp_acceleration`` (m/s^2: tangential and centripetal, the vector's length),
    (n,), ``inf`` where it is not limited. Between two points the smaller limit of both holds."""

    velocity: FloatArray
    acceleration: FloatArray
    tcp_speed: FloatArray
    tcp_acceleration: FloatArray
    rows: FloatArray
    follower_velocity: FloatArray
    follower_acceleration: FloatArray

    def coordinates(self, q: FloatArray, length: FloatArray,
                    tcp: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The path's coordinates at the points (joints, limited followers, and where the end effector is
        limited anywhere its arc length and its position ``tcp`` (n, 3) along each of
        ``tcp_directions``) with their velocity and acceleration limits, one row per point. Linear in the
        joints or the TCP position, each coordinate's spline is that combination of theirs, so limiting
        the components limits the vector (``tcp_directions``)."""
        coords, vlim, alim = q, self.velocity, self.acceleration
        if len(self.rows):
            # the limited followers as more coordinates of the spline (linear in the joints, so exact)
            coords = np.hstack([coords, q @ self.rows.T])
            vlim = np.hstack([vlim, self.follower_velocity])
            alim = np.hstack([alim, self.follower_acceleration])
        if np.isfinite(self.tcp_speed).any():
            half, cover = tcp_directions()
            along = tcp @ half.T
            coords = np.hstack([coords, length[:, None], along])
            vlim = np.hstack([vlim, self.tcp_speed[:, None], np.full(along.shape, math.inf)])
            alim = np.hstack([alim, self.tcp_acceleration[:, None],
                              np.repeat(self.tcp_acceleration[:, None] * cover, along.shape[1], axis=1)])
        # a limit that does not hold somewhere: one no motion of a robot reaches (toppra needs numbers)
        return coords, np.minimum(vlim, UNLIMITED), np.minimum(alim, UNLIMITED)

    def kept(self, keep: npt.NDArray[np.bool_]) -> CurveLimits:
        """The rows of the points ``keep`` selects."""
        return replace(self, velocity=self.velocity[keep], acceleration=self.acceleration[keep],
                       tcp_speed=self.tcp_speed[keep], tcp_acceleration=self.tcp_acceleration[keep],
                       follower_velocity=self.follower_velocity[keep],
                       follower_acceleration=self.follower_acceleration[keep])


def _between(knots: FloatArray, rows: FloatArray) -> Callable[[FloatArray], FloatArray]:
    """Limits at path parameters: the smaller of the rows of the two points around each (at a point, of it
    and its neighbours)."""
    last = len(knots) - 1

    def at(s: FloatArray) -> FloatArray:
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        hi = np.clip(np.searchsorted(knots, s, side="right"), 0, last)
        lo = np.clip(np.searchsorted(knots, s, side="left") - 1, 0, last)
        out: FloatArray = np.minimum(rows[lo], rows[hi])
        return out

    return at


@functools.lru_cache(maxsize=64)
def _fixed_constraints(vlim: bytes, alim: bytes) -> tuple[object, object]:
    """toppra's joint velocity and acceleration constraints of limits that hold all along a curve (each
    coordinate's limit, float64 bytes). Made once per limits: their constructors write the limits out as
    text (numpy's array formatting, costlier than timing a short curve), and a solve keeps nothing in them
    (it only reads their limits), so one object serves every curve and thread."""
    import toppra.constraint

    v, a = np.frombuffer(vlim), np.frombuffer(alim)
    return (toppra.constraint.JointVelocityConstraint(np.stack([-v, v], axis=1)),
            toppra.constraint.JointAccelerationConstraint(np.stack([-a, a], axis=1)))


def _acceleration_constraint(limit_at: Callable[[FloatArray], FloatArray]) -> object:
    """TOPP-RA's joint acceleration constraint with limits that change along the path: each coordinate's
    acceleration divided by its limit there kept within [-1, 1] (toppra's own constraint takes one limit
    for the whole path)."""
    from toppra.constraint import DiscretizationType, LinearConstraint
    from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate

    class VaryingAcceleration(LinearConstraint):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.identical = True
            self.set_discretization_type(DiscretizationType.Interpolation)

        def compute_constraint_params(self, path: Any, gridpoints: FloatArray) -> Any:
            limits = limit_at(gridpoints)
            self.dof = path.dof
            ps = np.asarray(path(gridpoints, 1)).reshape(-1, path.dof) / limits
            pss = np.asarray(path(gridpoints, 2)).reshape(-1, path.dof) / limits
            eye = np.eye(path.dof)
            return canlinear_colloc_to_interpolate(ps, pss, np.zeros_like(ps), np.vstack([eye, -eye]),
                                                   np.ones(2 * path.dof), None, None, gridpoints,
                                                   identical=True)

    return VaryingAcceleration()


def load_timing() -> None:
    """Imports TOPP-RA (and what it imports) on a thread of its own, once per process, so the first curve
    a servient times does not wait for it (``planning.warmUp``)."""
    global _timing_started
    with _timing_lock:
        if _timing_started:
            return
        _timing_started = True

    def load() -> None:
        import toppra.algorithm
        import toppra.constraint  # noqa: F401

    threading.Thread(target=load, name="robwot-timing", daemon=True).start()


_timing_lock = threading.Lock()
_timing_started = False


def plan_curve_path(
    points: Sequence[FloatArray],
    arc: Sequence[float],
    limits: CurveLimits,
    dt: float,
    bounds: tuple[FloatArray, FloatArray],
    tcp: Sequence[Sequence[float]] | None = None,
) -> Curve | Straight:
    """The timed cubic spline through ``points`` (the first is the start, the last the target): states one
    per ``dt``, at rest at both ends, time-optimal (TOPP-RA) under ``limits`` (the joints', the followers'
    and the end effector's along the curve), the end effector's arc length at each point being ``arc``
    (metres, from 0, increasing), its position ``tcp`` (m, one per point; needed where it is limited).
    States are clipped to ``bounds`` (lower, upper): the spline through samples within the limits may
    overshoot one by a hair between two of them."""
    import toppra
    import toppra.algorithm
    import toppra.constraint
    from scipy.interpolate import CubicSpline

    toppra.setup_logging("WARNING")
    q = np.asarray(points, dtype=np.float64)
    length = np.asarray(arc, dtype=np.float64)
    # the path parameter: the samples' order, by distance in joint space and along the curve (both may
    # stand still while the other moves: a turn in place, a joint-space wobble)
    gaps = np.linalg.norm(np.diff(q, axis=0), axis=1) + np.abs(np.diff(length))
    keep = np.concatenate([[True], gaps > 0])
    if keep.sum() < 2:
        return Straight(q[0], q[0], 0.0, 0.0, 1.0, 0)
    knots = np.concatenate([[0.0], np.cumsum(gaps)])
    knots /= knots[-1]  # exactly 1 at the end, as the grid's
    at = np.zeros((len(keep), 3)) if tcp is None else np.asarray(tcp, dtype=np.float64)
    if tcp is None and np.isfinite(limits.tcp_speed).any():
        raise ValueError("an end effector limited along a curve needs its positions")
    q, length, ss = q[keep], length[keep], knots[keep]
    waypoints, vlim, alim = limits.kept(keep).coordinates(q, length, at[keep])
    spline = CubicSpline(ss, waypoints, bc_type="not-a-knot")  # the spline toppra's interpolator makes
    path = toppra.SplineInterpolator(ss, waypoints, bc_type="not-a-knot")
    if np.all(vlim == vlim[0]) and np.all(alim == alim[0]):  # the same limits all along: toppra's own
        constraints = list(_fixed_constraints(vlim[0].astype(np.float64).tobytes(),
                                              alim[0].astype(np.float64).tobytes()))
    else:
        velocity_at = _between(ss, vlim)
        constraints = [
            toppra.constraint.JointVelocityConstraintVarying(
                lambda s: np.stack([-velocity_at(s)[0], velocity_at(s)[0]], axis=1)),
            _acceleration_constraint(_between(ss, alim))]
    # TOPP-RA's grid: the samples, and twice as many evenly spread where they are few (a LIN's, 5 mm
    # apart); a densely sampled curve (a detour's, every 0.02 rad) is timed on its samples alone
    extra = np.linspace(0.0, 1.0, 2 * len(ss)) if len(ss) <= DENSE else np.empty(0)
    grid = np.unique(np.concatenate([ss, extra]))
    algorithm = toppra.algorithm.TOPPRA(constraints, path, gridpoints=grid,
                                        parametrizer="ParametrizeConstAccel")
    speeds = None if algorithm.compute_trajectory(0.0, 0.0) is None else algorithm.problem_data.sd_vec
    if speeds is None or not np.all(speeds[:-1] + speeds[1:] > 0):
        raise InvalidParams("no time parametrisation of the curve meets the joint limits", param="path")
    lower, upper = bounds
    curve = Curve(spline, np.asarray(algorithm.problem_data.gridpoints, dtype=np.float64),
                  np.asarray(speeds, dtype=np.float64), q.shape[1], lower, upper, q[0], q[-1], 1, knots)
    return replace(curve, steps=max(1, _steps(curve.duration, dt)))


#: rounds of widening or slowing a jerk-limited curve until its sampled peaks are within the limits
JERK_ROUNDS = 8
#: how far above a limit a finite-difference peak may lie (the samples' own error)
JERK_TOLERANCE = 0.02


def _jerk_window(amax: float, duration: float, peak: float, jerk: float) -> float:
    """The window (s) that keeps a trapezoid's fraction (acceleration ``amax``, ``duration`` s, cruising
    at ``peak``) within ``jerk`` when averaged over it (``Profile.smoothed``): its jerk is then
    (a(t) - a(t - w)) / w, a the trapezoid's acceleration (+A, 0, -A): with a cruise at least as long as
    the window no two phases ramp against each other, w = A / J (the time-optimal jerk-limited profile of
    a line reaching both limits), else 2 A / J."""
    window = amax / jerk
    return window if duration - 2 * peak / amax >= window else 2 * window


def _jerk_limited_line(vmax: float, amax: float, jerk: float, dt: float, start: FloatArray,
                       target: FloatArray) -> Straight:
    """The fastest averaged trapezoid (``_jerk_window``) of a line whose fraction may go ``vmax``,
    ``amax`` and ``jerk``: a lower acceleration than ``amax`` shortens the window more than it lengthens
    the trapezoid when the jerk is low, so the acceleration is chosen among 48 between amax / 1000 and
    amax (the largest time found is within the grid's step of the best)."""
    best: tuple[float, float, float, float] | None = None
    for a in amax * np.geomspace(1e-3, 1.0, 48):
        duration, peak = trapezoid(1.0, vmax, float(a))
        total = duration + _jerk_window(float(a), duration, peak, jerk)
        if best is None or total < best[0]:
            best = (total, float(a), duration, peak)
    assert best is not None
    total, a, duration, peak = best
    return Straight(start, target, duration, peak, a, max(1, _steps(total, dt)), total - duration)


def _peaks(curve: Curve) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Each joint's largest |velocity|, |acceleration| and |jerk| along ``curve`` as it is timed, by
    finite differences of its states at a fine, even time step."""
    n = int(min(20_000, max(400, 4 * curve.steps)))
    h = curve.span / n
    q = curve.states(curve.progress(np.arange(n + 1, dtype=np.float64) * (curve.steps / n)))
    v, a, j = (np.abs(np.diff(q, k, axis=0)).max(axis=0) / h**k for k in (1, 2, 3))
    return v, a, j


def jerk_limited_curve(curve: Curve, jerk: FloatArray, velocity: FloatArray, acceleration: FloatArray,
                       dt: float) -> Curve:
    """``curve`` with every joint's jerk within ``jerk`` (inf: none), its velocity and acceleration still
    within ``velocity`` and ``acceleration``: its TOPP-RA profile averaged over a window (the parameter's
    jerk then (a(t) - a(t - w)) / w), the window from the largest change of the parameter's acceleration
    and each joint's largest slope (the profile first slowed where that makes the whole shorter), then
    checked by sampling: a jerk still above its limit first widens the
    window, then, like a velocity or acceleration above its limit, slows the whole profile (time x k:
    velocity / k, acceleration / k^2, jerk / k^3, every term of it)."""
    limited = np.isfinite(jerk)
    if curve.steps == 0 or not limited.any():
        return curve
    accel = curve.profile.accel
    jump = max(float(accel.max()), 0.0) - min(float(accel.min()), 0.0)
    slopes = np.array([curve.slope_bound(np.eye(curve.dof)[j]) for j in range(curve.dof)])
    window = max(1e-3, float(np.max(slopes[limited] * jump / jerk[limited])))
    # slowed by k the profile's accelerations and so the window shrink by k^2: the time k T + w / k^2 is
    # least at k = (2 w / T)^(1/3) (a low jerk limit: a slower profile rather than a long window)
    k = max(1.0, (2.0 * window / curve.duration) ** (1 / 3))
    curve, window = replace(curve, speeds=curve.speeds / k), window / k**2
    for rounds in range(JERK_ROUNDS):
        out = replace(curve, window=window, steps=max(1, _steps(curve.duration + window, dt)))
        v, a, j = _peaks(out)
        over_v, over_a = float(np.max(v / velocity)), float(np.max(a / acceleration))
        over_j = float(np.max(j[limited] / jerk[limited]))
        if max(over_v, over_a, over_j) <= 1.0 + JERK_TOLERANCE:
            return out
        if rounds == 0 and max(over_v, over_a) <= 1.0 + JERK_TOLERANCE:
            # the window's part of the jerk falls with its width; the path's curvature's does not
            window *= over_j
            continue
        k = max(over_v, math.sqrt(over_a), over_j ** (1 / 3), 1.0) * (1.0 + JERK_TOLERANCE)
        curve = replace(curve, speeds=curve.speeds / k)
        window *= k
    return replace(curve, window=window, steps=max(1, _steps(curve.duration + window, dt)))
