"""The random-program bench's independent time-optimal bound of a plan (``bound``), and its rests.

None of the planner's timing code is used. The plan's trajectory is asked at 240 Hz (the backend's states at
dt 1/240 s; a long program gets a lower rate) and its samples are the joint path. The path is cut where the
robot must rest: the program's start and end, the end of every step without ``blend`` (the sample of least
speed within 3 of the end the reported durations give), and every rest of the trajectory (a local minimum of
the joint speed below ``REST_SPEED``) where the direction of motion turns by ``STRAIGHT_DEG`` or more (a
corner: no motion passes a corner of a joint path without stopping; directions to the nearest samples
>= 1e-3 rad away). A rest on a straight line is not cut: the bound moves through it. Each piece between two
cuts (end samples turning > 10 degrees off it dropped: the rest falls between two samples) is timed rest to
rest:

- a straight piece (every sample within 1e-6 of its length off the chord) inside one PTP step: the closed
  form trapezoid along the chord, path velocity ``min_j v_j/|d_j|`` and acceleration ``min_j a_j/|d_j|``;
- any other piece: TOPP-RA (``toppra``, seidel solver, constant-acceleration parametrisation, 300-3000
  grid points) along a cubic spline through the samples (thinned to at most 600 evenly spaced along the
  joint path), parametrised by joint-space arc length, with limits varying along the path as the step
  each sample belongs to (by the steps' reported durations) asks: joint velocity ``v_j * speed`` and
  acceleration ``v_j / 0.25 s * acceleration`` (the contract's ``x-accelerationTime``: these arms have no
  acceleration limits), and on LIN / CIRC samples (a blend's halves belong to their steps so) the TCP's
  speed ``tcpSpeed`` on the TCP's arc length and its total acceleration (tangential and centripetal, the
  vector's length) within ``A = x-tcpAcceleration * acceleration``, the limit the planner keeps. TOPP-RA
  takes limits linear in the path, and ``|a| <= A`` is not; the bound relaxes it: the TCP position's
  component along each of ``TCP_DIRECTIONS`` directions over a hemisphere (a Fibonacci spiral; with their
  opposites 256 over the sphere) is one more path coordinate, its acceleration within the full ``A`` (and
  the arc length's, the tangential acceleration, too). Every acceleration with ``|a| <= A`` keeps these,
  so the relaxed problem's optimum is never slower than the true one: the bound stays a lower bound on time
  (it lets ``|a|`` reach ``A`` / cos of the widest angle to the nearest direction, 10.8 degrees: 1.8 %
  over ``A``; the planner instead limits 50 directions to ``A`` x that cosine less a degree, inside
  ``|a| <= A``). The TCP positions are Pinocchio's FK of the tool URDF's ``robwot_tcp`` at every sample
  (``Kin``); the limits on PTP samples are 1e3 (none). Limits varying per grid point are written as
  constraints here (``topp_time``), checked against ``toppra``'s own on constant limits by the test.

The bound is the sum over the pieces (``PIECES`` keeps each piece's bound and the plan's own time for it).
A plan within its limits is never faster than the time-optimal motion along its own path, so a piece whose
bound exceeds the plan's own time counts where the bound (or the plan's limits) is wrong. The bound follows
the plan's own path (detour and blend geometry included): it measures the timing, not the path.

Rests (``rests``): as above, away from the program's start and end and the ends of steps without blend;
"straight rests" among them turn by less than ``STRAIGHT_DEG`` (a detour stopping at a waypoint on a
straight line).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_bench.program_kin import Kin
from robwot_sim.limits import TCP_ACCELERATION

F = npt.NDArray[np.float64]

#: rad/s (joint-space norm): a local minimum of the joint speed below this is a rest
REST_SPEED = 0.05
#: degrees: a rest where the direction turns less than this is a straight rest
STRAIGHT_DEG = 0.05
#: directions over a hemisphere along which the TCP's acceleration is limited (each also opposite)
TCP_DIRECTIONS = 128


@functools.cache
def tcp_directions() -> F:
    """``TCP_DIRECTIONS`` unit vectors spread over the upper hemisphere (a Fibonacci spiral)."""
    i = np.arange(TCP_DIRECTIONS) + 0.5
    z = 1.0 - i / TCP_DIRECTIONS
    r, turn = np.sqrt(1.0 - z * z), math.pi * (1.0 + math.sqrt(5.0)) * i
    out: F = np.stack([r * np.cos(turn), r * np.sin(turn), z], axis=1)
    return out




@dataclass
class Limits:
    vmax: F
    amax: F


def trapezoid(d: F, v: F, a: F) -> float:
    """Rest-to-rest time along the chord ``d`` (closed form)."""
    nz = np.abs(d) > 1e-12
    if not nz.any():
        return 0.0
    vs = float(np.min(v[nz] / np.abs(d[nz])))
    acc = float(np.min(a[nz] / np.abs(d[nz])))
    if vs * vs / acc >= 1.0:  # triangle: never reaches vs on s in [0, 1]
        return 2 * math.sqrt(1.0 / acc)
    return 1.0 / vs + vs / acc


def topp_time(q: F, vlim: F, alim: F, joints: int) -> float:
    """TOPP-RA rest to rest along the spline through the rows of ``q`` [n, dim] (the first ``joints``
    columns the joints, by whose arc length it is parametrised), limits per row [n, dim]."""
    import toppra
    import toppra.algorithm
    from toppra.constraint import DiscretizationType, LinearConstraint
    from toppra.constraint.linear_constraint import canlinear_colloc_to_interpolate

    toppra.setup_logging("WARNING")
    seg = np.linalg.norm(np.diff(q[:, :joints], axis=0), axis=1)
    seg = np.maximum(seg, np.linalg.norm(np.diff(q, axis=0), axis=1) * 1e-3)
    ss = np.concatenate([[0.0], np.cumsum(seg)])
    path = toppra.SplineInterpolator(ss, q)
    dim = q.shape[1]

    def limits_at(s: F, table: F) -> F:
        idx = np.clip(np.searchsorted(ss, s), 0, len(ss) - 1)
        out: F = table[idx]
        return out

    class Velocity(LinearConstraint):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.dof = dim
            self.discretization_type = DiscretizationType.Collocation

        def compute_constraint_params(self, path: Any, grid: F, *args: Any, **kw: Any) -> Any:
            d = np.abs(path(grid, 1)).reshape(-1, dim)
            lim = limits_at(grid, vlim)
            with np.errstate(divide="ignore"):
                x = np.where(d > 1e-12, (lim / np.maximum(d, 1e-300)) ** 2, np.inf).min(axis=1)
            xb = np.stack([np.zeros_like(x), np.minimum(x, 1e8)], axis=1)
            return None, None, None, None, None, None, xb

    class Acceleration(LinearConstraint):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.dof = dim
            self.discretization_type = DiscretizationType.Interpolation
            self.identical = True

        def compute_constraint_params(self, path: Any, grid: F, *args: Any, **kw: Any) -> Any:
            lim = limits_at(grid, alim)
            a = path(grid, 1).reshape(-1, dim) / lim
            b = path(grid, 2).reshape(-1, dim) / lim
            fm = np.vstack([np.eye(dim), -np.eye(dim)])
            g = np.ones(2 * dim)
            return canlinear_colloc_to_interpolate(a, b, np.zeros_like(a), fm, g, None, None, grid,
                                                   identical=True)

    n = int(min(3000, max(300, 2 * len(q))))
    for grid_n in (n, n // 2 + 1, n * 2):  # a badly conditioned grid is tried again at another density
        grid = np.linspace(0, ss[-1], grid_n)
        algo = toppra.algorithm.TOPPRA([Velocity(), Acceleration()], path, gridpoints=grid,
                                       parametrizer="ParametrizeConstAccel")
        traj = algo.compute_trajectory(0.0, 0.0)
        if traj is not None:
            return float(traj.duration)
    raise RuntimeError("TOPP-RA found no parametrisation")


def _dedup(q: F) -> tuple[F, npt.NDArray[np.int64]]:
    keep = np.concatenate([[True], np.abs(np.diff(q, axis=0)).max(axis=1) > 1e-9])
    out: F = q[keep]
    return out, np.flatnonzero(keep)


def _trim(q: F, keep: npt.NDArray[np.int64]) -> tuple[F, npt.NDArray[np.int64]]:
    """A piece without its end samples that turn off its path by more than 10 degrees: a rest falls
    between two samples, and the one nearest it may already lie on the next piece (by some 1e-5 rad)."""
    def turn(a: F, b: F) -> float:
        c = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
        return math.degrees(math.acos(max(-1.0, min(1.0, c))))

    for _ in range(2):
        if len(q) >= 3 and turn(q[-2] - q[-3], q[-1] - q[-2]) > 10:
            q, keep = q[:-1], keep[:-1]
        if len(q) >= 3 and turn(q[1] - q[0], q[2] - q[1]) > 10:
            q, keep = q[1:], keep[1:]
    return q, keep


def step_index(plan: dict[str, Any]) -> npt.NDArray[np.int64]:
    """The step each trajectory sample belongs to, by the reported durations."""
    traj = plan["trajectory"]
    n = len(traj["positions"])
    t = np.arange(n) * float(traj["dt"])
    ends = np.cumsum([float(s["duration"]) for s in plan["steps"]])
    return np.clip(np.searchsorted(ends, t - 1e-9, side="left"), 0, len(ends) - 1).astype(np.int64)


def _speed(q: F, dt: float) -> F:
    """Joint-space speed at each sample (mean of the neighbouring differences)."""
    if len(q) < 2:
        return np.zeros(len(q))
    v = np.linalg.norm(np.diff(q, axis=0), axis=1) / dt
    out: F = np.concatenate([[v[0]], (v[:-1] + v[1:]) / 2, [v[-1]]])
    return out


def forced_rests(plan: dict[str, Any], steps: list[dict[str, Any]]) -> set[int]:
    """Sample indices where the program must rest: start, end, ends of steps without blend (the sample of
    least speed within 3 of the step's reported end)."""
    traj = plan["trajectory"]
    q = np.asarray(traj["positions"], dtype=np.float64)
    n = len(q)
    dt = float(traj["dt"])
    speed = _speed(q, dt)
    out = {0, n - 1}
    t = 0.0
    for k, s in enumerate(plan["steps"]):
        t += float(s["duration"])
        if not steps[k].get("blend"):
            at = min(n - 1, round(t / dt))
            lo, hi = max(0, at - 3), min(n, at + 4)
            out.add(lo + int(np.argmin(speed[lo:hi])))
    return out


def rest_points(plan: dict[str, Any], steps: list[dict[str, Any]]) -> list[tuple[int, float]]:
    """The samples where the trajectory rests (a local minimum of the joint speed below ``REST_SPEED``)
    away from the forced rests (see ``forced_rests``), with the angle (degrees) the direction of motion
    turns there (directions to the nearest samples at least 1e-3 rad away on either side)."""
    q = np.asarray(plan["trajectory"]["positions"], dtype=np.float64)
    if len(q) < 5:
        return []
    speed = _speed(q, float(plan["trajectory"]["dt"]))
    forced = forced_rests(plan, steps)
    out: list[tuple[int, float]] = []
    for i in range(1, len(q) - 1):
        if speed[i] >= REST_SPEED or speed[i] > speed[max(0, i - 2):i + 3].min():
            continue
        if speed[i - 1] == speed[i] or any(abs(i - f) <= 3 for f in forced):
            continue
        before = np.flatnonzero(np.linalg.norm(q[:i] - q[i], axis=1) >= 1e-3)
        after = np.flatnonzero(np.linalg.norm(q[i + 1:] - q[i], axis=1) >= 1e-3)
        if not len(before) or not len(after):
            continue
        da = q[i] - q[before[-1]]
        db = q[i + 1 + after[0]] - q[i]
        c = float(da @ db / (np.linalg.norm(da) * np.linalg.norm(db)))
        out.append((i, math.degrees(math.acos(max(-1.0, min(1.0, c))))))
    return out


def rests(plan: dict[str, Any], steps: list[dict[str, Any]]) -> tuple[int, int]:
    """(rests inside the program, those where the direction turns < STRAIGHT_DEG)."""
    found = rest_points(plan, steps)
    return len(found), sum(1 for _, turn in found if turn < STRAIGHT_DEG)


#: (first sample, last sample, bound s, the plan's own time s, how) of every piece of the last ``bound``
PIECES: list[tuple[int, int, float, float, str]] = []


def bound(plan: dict[str, Any], steps: list[dict[str, Any]], lim: Limits, kin: Kin) -> float:
    """The independent time-optimal bound of the plan's path (see the module docstring)."""
    q = np.asarray(plan["trajectory"]["positions"], dtype=np.float64)
    dt = float(plan["trajectory"]["dt"])
    owner = step_index(plan)
    cuts = forced_rests(plan, steps) | {i for i, turn in rest_points(plan, steps) if turn >= STRAIGHT_DEG}
    marks = sorted(cuts | {0, len(q) - 1})
    PIECES.clear()
    total = 0.0
    for a, b in itertools.pairwise(marks):
        piece, keep = _trim(*_dedup(q[a:b + 1]))
        if len(piece) < 2:
            continue
        own = owner[a:b + 1][keep].copy()
        if len(own) > 2:  # a piece's end samples belong to the step of its inside
            own[0], own[-1] = own[1], own[-2]
        t, how = _piece_time(piece, own, steps, lim, kin)
        PIECES.append((a, b, t, (b - a) * dt, how))
        total += t
    return total


def _piece_time(piece: F, own: npt.NDArray[np.int64], steps: list[dict[str, Any]], lim: Limits,
                kin: Kin) -> tuple[float, str]:
    """Rest-to-rest time of one piece: the trapezoid when straight inside one PTP step, else TOPP-RA."""
    cart = np.array([steps[int(k)].get("motion", "ptp") in ("lin", "circ") for k in own])
    spd = np.array([float(steps[int(k)].get("speed", 1.0)) for k in own])
    acc = np.array([float(steps[int(k)].get("acceleration", 1.0)) for k in own])
    chord = piece[-1] - piece[0]
    lc = float(np.linalg.norm(chord))
    off = np.inf
    if lc > 0:
        rel = piece - piece[0]
        along = rel @ chord / lc
        off = float(np.linalg.norm(rel - np.outer(along, chord / lc), axis=1).max())
    if len(set(own.tolist())) == 1 and not cart.any() and off <= 1e-6 * lc + 1e-9:
        return trapezoid(chord, lim.vmax * spd[0], lim.amax * acc[0]), "trapezoid"
    # thin to at most 600 samples evenly spaced along the joint path (dense clusters at rests dropped)
    arclen = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(piece, axis=0), axis=1))])
    if len(piece) > 600:
        sel = np.unique(np.searchsorted(arclen, np.linspace(0, arclen[-1], 600)).clip(0, len(piece) - 1))
        sel = np.unique(np.concatenate([[0], sel, [len(piece) - 1]]))
        piece, own, spd, acc, cart = piece[sel], own[sel], spd[sel], acc[sel], cart[sel]
    vl = np.outer(spd, lim.vmax)
    al = np.outer(acc, lim.amax)
    if cart.any():
        tcp = np.array([float(steps[int(k)].get("tcpSpeed", 0.25)) if c else 1e3
                        for k, c in zip(own, cart, strict=True)])
        piece, vl, al = with_tcp(piece, vl, al, np.array([kin.fk(x)[0] for x in piece]), tcp,
                                 np.where(cart, TCP_ACCELERATION * acc, 1e3))
    if len(piece) == 2:
        piece = np.linspace(piece[0], piece[1], 3)
        vl, al = np.vstack([vl, vl[-1:]]), np.vstack([al, al[-1:]])
    return topp_time(piece, vl, al, len(lim.vmax)), "toppra"



def with_tcp(q: F, vl: F, al: F, pts: F, tcp_speed: F, tcp_acc: F) -> tuple[F, F, F]:
    """The path's coordinates and limits with the TCP's: its arc length (speed ``tcp_speed``, tangential
    acceleration ``tcp_acc``) and its position ``pts`` (n, 3) along each of ``tcp_directions`` (no speed
    limit, acceleration ``tcp_acc`` each: the relaxation of the total acceleration's length, see the module
    docstring). Linear in the position, each direction's spline is that combination of the position's."""
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    along = pts @ tcp_directions().T
    k = along.shape[1]
    coords = np.hstack([q, arc[:, None], along])
    vlim = np.hstack([vl, tcp_speed[:, None], np.full((len(q), k), 1e3)])
    alim = np.hstack([al, tcp_acc[:, None], np.repeat(tcp_acc[:, None], k, axis=1)])
    return coords, vlim, alim
