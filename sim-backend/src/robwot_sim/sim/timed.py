"""A timed joint path whose states, one per ``dt``, are computed when asked for (pure numpy/scipy).

A motion runs states exactly ``dt`` apart, so a slow one has millions of them (a 10 minute step at the
smallest ``dt`` has six million). Nothing that plans needs them all at once: the collision check is
geometric (``pathcheck.py``: a straight piece by its ends, a curve at points spaced by how far the robot
travels along it), a program's report samples them at a bounded count, a run takes them in order, a chunk
at a time. So a path keeps its pieces, each a closed-form timing of its geometry, and computes the states
asked for: what planning costs does not grow with the duration (1 / speed, 1 / acceleration, 1 / dt).

Two kinds of piece, each with a ``progress`` along it in [0, 1] (how far along its geometry a state is):

- `Straight`: rest to rest on the line between two states, the line's fraction on a trapezoidal profile;
- `Curve`: along a cubic spline through samples (path parameter in [0, 1]), the parameter moving with
  piecewise constant acceleration (TOPP-RA's profile), states clipped to the joint limits.

A piece's ``steps`` states after its first are equally spaced in time: its profile is slowed uniformly to
fill whole steps of at most ``dt``. Consecutive pieces of a `TimedPath` share their boundary state (the
end of one is the start of the next), counted once.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, Protocol

import numpy as np
import numpy.typing as npt

from robwot_sim.sim.types import FloatArray

if TYPE_CHECKING:  # scipy.interpolate costs the backend's start a tenth of a second; motion.py imports it
    from scipy.interpolate import CubicSpline

IntArray = npt.NDArray[np.int64]


class Piece(Protocol):
    """One piece of a timed path: ``steps`` time steps (``steps + 1`` states, 0 when it stands still)."""

    @property
    def steps(self) -> int: ...

    def at(self, k: IntArray) -> FloatArray:
        """The states at step indices ``k`` (each in [0, steps]), one row each."""
        ...

    def progress(self, k: FloatArray) -> FloatArray:
        """How far along the piece's geometry (in [0, 1], non-decreasing) the state at step ``k`` is."""
        ...

    def index_of(self, progress: float) -> float:
        """The (fractional) step index at which the piece reaches ``progress``: between two steps, the
        fraction of the progress from one to the next (so states interpolated linearly at it lie on the
        chord between those two states)."""
        ...


def _fractional_index(piece: Piece, continuous: float, progress: float) -> float:
    """``index_of`` from the exact (continuous) index: the step before it, then linear in progress."""
    if piece.steps == 0:
        return 0.0
    k0 = min(max(0, math.floor(continuous)), piece.steps - 1)
    p0, p1 = (float(v) for v in piece.progress(np.array([k0, k0 + 1], dtype=np.float64)))
    if p1 <= p0:
        return float(k0)
    return k0 + min(1.0, max(0.0, (progress - p0) / (p1 - p0)))


@dataclass(frozen=True)
class Profile:
    """A path parameter under piecewise constant acceleration: at ``times`` (s, from 0, non-decreasing)
    it is at ``at`` with speed ``speed``, accelerating uniformly between two of them; before the first it
    stands at the first value, after the last at the last one. What a window (``smoothed``) needs: the
    parameter, its speed and acceleration at any time, and its integral over time, all exact."""

    times: FloatArray
    at: FloatArray
    speed: FloatArray

    @cached_property
    def accel(self) -> FloatArray:
        gap = np.diff(self.times)
        out: FloatArray = np.divide(np.diff(self.speed), gap, out=np.zeros(len(gap)), where=gap > 0)
        return out

    @cached_property
    def _integral(self) -> FloatArray:
        """The integral of the parameter from 0 to each of ``times``."""
        gap = np.diff(self.times)
        cells = self.at[:-1] * gap + self.speed[:-1] * gap**2 / 2 + self.accel * gap**3 / 6
        out: FloatArray = np.concatenate([[0.0], np.cumsum(cells)])
        return out

    def _cell(self, t: FloatArray) -> tuple[npt.NDArray[np.intp], FloatArray]:
        i = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        return i, np.clip(t, self.times[0], self.times[-1]) - self.times[i]

    def value(self, t: FloatArray) -> FloatArray:
        i, tau = self._cell(t)
        out: FloatArray = self.at[i] + self.speed[i] * tau + self.accel[i] * tau**2 / 2
        return out

    def integral(self, t: FloatArray) -> FloatArray:
        """The parameter's integral over time from 0 to ``t`` (0 before, growing at the last value after)."""
        t = np.asarray(t, dtype=np.float64)
        i, tau = self._cell(t)
        inside = (self._integral[i] + self.at[i] * tau + self.speed[i] * tau**2 / 2
                  + self.accel[i] * tau**3 / 6)
        after = np.maximum(t - self.times[-1], 0.0) * self.at[-1]
        out: FloatArray = np.where(t <= self.times[0], 0.0, inside + after)
        return out

    def smoothed(self, t: FloatArray, window: float) -> FloatArray:
        """The parameter averaged over the ``window`` (s) before ``t``: its acceleration then changes at
        most by the largest jump of the original's within a window, spread over the window (bounded jerk),
        its speed and acceleration stay within the original's range; ``window`` longer than the motion."""
        t = np.asarray(t, dtype=np.float64)
        out: FloatArray = (self.integral(t) - self.integral(t - window)) / window
        return out


def _smoothed_index(piece: Piece, profile: Profile, window: float, span: float, progress: float) -> float:
    """``index_of`` of a piece timed by ``profile`` averaged over ``window``: the time by bisection (the
    average is non-decreasing in time), then linear in progress between the two steps around it."""
    lo, hi = 0.0, span
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if float(profile.smoothed(np.array([mid]), window)[0]) < progress:
            lo = mid
        else:
            hi = mid
    return _fractional_index(piece, hi / span * piece.steps, progress)


@dataclass(frozen=True)
class Straight:
    """From ``start`` to ``target`` on the line, the line's fraction on the rest-to-rest trapezoid of
    ``peak`` (fraction/s) and ``amax`` (fraction/s^2) lasting ``duration`` s, sampled at ``steps`` equal
    time steps (the last state is ``target`` exactly)."""

    start: FloatArray
    target: FloatArray
    duration: float
    peak: float
    amax: float
    steps: int
    #: seconds the trapezoid's fraction is averaged over (``Profile.smoothed``): 0, or a jerk-limited motion
    #: ``window`` longer
    window: float = 0.0

    @cached_property
    def profile(self) -> Profile:
        """The trapezoid as a `Profile` of the line's fraction."""
        ramp = min(self.peak / self.amax, self.duration / 2)
        times = np.array([0.0, ramp, self.duration - ramp, self.duration])
        return Profile(times, self._fraction(times), np.array([0.0, self.peak, self.peak, 0.0]))

    @property
    def span(self) -> float:
        """Seconds from its first state to its last."""
        return self.duration + self.window

    def _fraction(self, t: FloatArray) -> FloatArray:
        """The line's fraction at profile times ``t`` (clamped to [0, duration])."""
        t = np.clip(t, 0.0, self.duration)
        ramp = self.peak / self.amax
        rise = 0.5 * self.amax * np.minimum(t, ramp) ** 2
        cruise = self.peak * np.clip(t - ramp, 0.0, max(0.0, self.duration - 2 * ramp))
        tail = np.clip(t - (self.duration - ramp), 0.0, ramp)
        fall = self.peak * tail - 0.5 * self.amax * tail**2
        out: FloatArray = np.minimum(rise + cruise + fall, 1.0)
        return out

    def progress(self, k: FloatArray) -> FloatArray:
        if self.steps == 0:
            return np.ones(len(k))
        t = np.asarray(k, dtype=np.float64) * (self.span / self.steps)
        if self.window > 0:
            return np.minimum(self.profile.smoothed(t, self.window), 1.0)
        return self._fraction(t)

    def at(self, k: IntArray) -> FloatArray:
        s = self.progress(np.asarray(k, dtype=np.float64))
        out: FloatArray = self.start[None, :] + s[:, None] * (self.target - self.start)[None, :]
        out[np.asarray(k) >= self.steps] = self.target
        return out

    def index_of(self, progress: float) -> float:
        if self.steps == 0:
            return 0.0
        if self.window > 0:
            return _smoothed_index(self, self.profile, self.window, self.span, min(1.0, max(0.0, progress)))
        ramp = self.peak / self.amax
        ramped = 0.5 * self.amax * ramp**2  # the fraction covered while speeding up (and slowing down)
        f = min(1.0, max(0.0, progress))
        if f <= ramped:
            t = math.sqrt(2.0 * f / self.amax)
        elif f <= 1.0 - ramped:
            t = ramp + (f - ramped) / self.peak
        else:
            t = self.duration - math.sqrt(max(0.0, 2.0 * (1.0 - f) / self.amax))
        return _fractional_index(self, t / self.duration * self.steps, f)


@dataclass(frozen=True)
class Curve:
    """Along ``spline`` (path parameter in [0, 1] -> joint values, possibly followed by more coordinates
    such as the end effector's arc length: only the first ``dof`` are states), the parameter moving with
    constant acceleration between the parameters ``grid``, at the parameter speeds ``speeds`` there (at
    rest at both ends); ``steps`` equal time steps; states clipped to [``lower``, ``upper``]; the first
    and last states are ``first`` and ``last`` exactly. ``knots``: the parameter of each sample the spline
    was made through, in order."""

    spline: CubicSpline
    grid: FloatArray
    speeds: FloatArray
    dof: int
    lower: FloatArray
    upper: FloatArray
    first: FloatArray
    last: FloatArray
    steps: int
    knots: FloatArray
    #: seconds the parameter's profile is averaged over (``Profile.smoothed``): 0, or a jerk-limited motion
    #: ``window`` longer
    window: float = 0.0

    @cached_property
    def profile(self) -> Profile:
        """The parameter's profile as a `Profile`."""
        return Profile(self._times, self.grid, self.speeds)

    @property
    def span(self) -> float:
        """Seconds from its first state to its last."""
        return self.duration + self.window

    @cached_property
    def _times(self) -> FloatArray:
        """Time (s) at each grid parameter: constant acceleration between them."""
        gaps = np.diff(self.grid) / (self.speeds[:-1] + self.speeds[1:])
        out: FloatArray = np.concatenate([[0.0], np.cumsum(2.0 * gaps)])
        return out

    @property
    def duration(self) -> float:
        return float(self._times[-1])

    def param_at(self, t: FloatArray) -> FloatArray:
        """The path parameter at times ``t`` (s)."""
        times = self._times
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, times[-1])
        i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
        v, gap = self.speeds[i], self.grid[i + 1] - self.grid[i]
        u = (self.speeds[i + 1] ** 2 - v**2) / (2.0 * gap)
        tau = t - times[i]
        out: FloatArray = np.clip(self.grid[i] + v * tau + 0.5 * u * tau**2, self.grid[i], self.grid[i + 1])
        return out

    def time_of(self, s: float) -> float:
        """The time (s) at which the parameter reaches ``s``."""
        times = self._times
        s = min(max(s, float(self.grid[0])), float(self.grid[-1]))
        i = min(max(int(np.searchsorted(self.grid, s, side="right")) - 1, 0), len(self.grid) - 2)
        v, gap = float(self.speeds[i]), float(self.grid[i + 1] - self.grid[i])
        u = (float(self.speeds[i + 1]) ** 2 - v * v) / (2.0 * gap)
        d = s - float(self.grid[i])
        # d = v tau + u tau^2 / 2, in the form that stays exact for u = 0 and v = 0
        root = math.sqrt(max(0.0, v * v + 2.0 * u * d))
        return float(times[i]) + (2.0 * d / (v + root) if v + root > 0 else 0.0)

    def states(self, s: FloatArray) -> FloatArray:
        """The (clipped) joint states at path parameters ``s``."""
        q = np.asarray(self.spline(np.asarray(s, dtype=np.float64)), dtype=np.float64)[:, : self.dof]
        out: FloatArray = np.clip(q, self.lower, self.upper)
        return out

    def progress(self, k: FloatArray) -> FloatArray:
        t = np.asarray(k, dtype=np.float64) * (self.span / self.steps)
        if self.window > 0:
            return np.clip(self.profile.smoothed(t, self.window), self.grid[0], self.grid[-1])
        return self.param_at(t)

    def at(self, k: IntArray) -> FloatArray:
        k = np.asarray(k)
        out = self.states(self.progress(k.astype(np.float64)))
        out[k <= 0] = self.first
        out[k >= self.steps] = self.last
        return out

    def index_of(self, progress: float) -> float:
        if self.window > 0:
            return _smoothed_index(self, self.profile, self.window, self.span, progress)
        return _fractional_index(self, self.time_of(progress) / self.duration * self.steps, progress)

    def monotone_params(self) -> FloatArray:
        """Parameters between which every joint coordinate of the spline moves one way only: its knots
        and the roots of each coordinate's derivative (a quadratic per interval)."""
        x = np.asarray(self.spline.x, dtype=np.float64)
        c = np.asarray(self.spline.c, dtype=np.float64)[:, :, : self.dof]  # (4, intervals, dof)
        a, b, cc = 3.0 * c[0], 2.0 * c[1], c[2]  # derivative a t^2 + b t + cc on [0, h]
        h = np.diff(x)[:, None]
        disc = b * b - 4.0 * a * cc
        roots = []
        with np.errstate(divide="ignore", invalid="ignore"):
            sq = np.sqrt(np.where(disc >= 0, disc, np.nan))
            quadratic = np.abs(a) > 1e-300
            roots.append(np.where(quadratic, (-b + sq) / (2.0 * a), np.nan))
            roots.append(np.where(quadratic, (-b - sq) / (2.0 * a), -cc / b))
        inner = [x[:-1, None] + r for r in roots]
        picked = [s[(r > 0) & (r < h)] for s, r in zip(inner, roots, strict=True)]
        return np.unique(np.concatenate([x, *picked]))

    def slope_bound(self, weights: FloatArray) -> float:
        """An upper bound of sum_j weights_j |dq_j/ds| over the whole spline (per interval, each joint's
        largest |derivative| at its ends or its vertex)."""
        x = np.asarray(self.spline.x, dtype=np.float64)
        c = np.asarray(self.spline.c, dtype=np.float64)[:, :, : self.dof]
        a, b, cc = 3.0 * c[0], 2.0 * c[1], c[2]
        h = np.diff(x)[:, None]
        ends = np.maximum(np.abs(cc), np.abs(a * h * h + b * h + cc))
        with np.errstate(divide="ignore", invalid="ignore"):
            vertex = np.where(np.abs(a) > 1e-300, -b / (2.0 * a), -1.0)
        inside = (vertex > 0) & (vertex < h)
        peak = np.where(inside, np.abs(a * vertex * vertex + b * vertex + cc), 0.0)
        return float(np.max(np.maximum(ends, peak) @ weights))

    def row_travel_bound(self, weights: FloatArray) -> float:
        """An upper bound of sum_j weights_j |q_j(k+1) - q_j(k)| between two consecutive states: one time
        step times the largest parameter speed times ``slope_bound`` (clipping only shortens moves)."""
        return self.span / self.steps * float(np.max(self.speeds)) * self.slope_bound(weights)


class TimedPath:
    """States one per ``dt``, ``len(path)`` of them, computed on demand from the pieces (module doc)."""

    def __init__(self, pieces: Sequence[Piece], dt: float) -> None:
        if not pieces:
            raise ValueError("a timed path needs a piece")
        self.pieces: tuple[Piece, ...] = tuple(pieces)
        self.dt = float(dt)
        self._ends = np.cumsum([p.steps for p in self.pieces], dtype=np.int64)

    @classmethod
    def still(cls, q: FloatArray, dt: float) -> TimedPath:
        """One state: ``q``."""
        q = np.asarray(q, dtype=np.float64)
        return cls([Straight(q, q, 0.0, 0.0, 1.0, 0)], dt)

    @classmethod
    def join(cls, paths: Sequence[TimedPath]) -> TimedPath:
        """The paths one after the other (each starting where the previous one ends), same ``dt``."""
        if any(p.dt != paths[0].dt for p in paths):
            raise ValueError("joined paths must share their dt")
        return cls([piece for p in paths for piece in p.pieces], paths[0].dt)

    @property
    def steps(self) -> int:
        return int(self._ends[-1])

    @property
    def duration(self) -> float:
        """Seconds from the first state to the last."""
        return self.steps * self.dt

    def __len__(self) -> int:
        return self.steps + 1

    def offsets(self) -> Iterator[tuple[int, Piece]]:
        """Each piece with the index (in the path) of its first state."""
        for end, piece in zip(self._ends, self.pieces, strict=True):
            yield int(end) - piece.steps, piece

    def rows(self, start: int = 0, stop: int | None = None, stride: int = 1) -> FloatArray:
        """The states ``start``, ``start + stride``, ... before ``stop`` (default: the end) as one array."""
        stop = len(self) if stop is None else min(stop, len(self))
        index = np.arange(start, stop, stride, dtype=np.int64)
        owner = np.minimum(np.searchsorted(self._ends, index, side="left"), len(self.pieces) - 1)
        out: FloatArray | None = None
        for p in np.unique(owner):
            piece = self.pieces[int(p)]
            mask = owner == p
            local = index[mask] - (int(self._ends[p]) - piece.steps)
            block = piece.at(local)
            if out is None:
                out = np.empty((len(index), block.shape[1]), dtype=np.float64)
            out[mask] = block
        if out is None:
            return np.empty((0, len(self.first)), dtype=np.float64)
        return out

    def __getitem__(self, i: int) -> FloatArray:
        n = len(self)
        if not -n <= i < n:
            raise IndexError(f"state {i} of a path of {n}")
        i = i % n
        row: FloatArray = self.rows(i, i + 1)[0]
        return row

    @property
    def first(self) -> FloatArray:
        row: FloatArray = self.pieces[0].at(np.zeros(1, dtype=np.int64))[0]
        return row

    @property
    def last(self) -> FloatArray:
        piece = self.pieces[-1]
        row: FloatArray = piece.at(np.array([piece.steps], dtype=np.int64))[0]
        return row

    def chunks(self, start: int = 0, size: int = 256) -> Iterator[FloatArray]:
        """The states from ``start`` on, ``size`` at a time (what a run needs, in order)."""
        for i in range(start, len(self), size):
            yield self.rows(i, i + size)
