"""How to reach a target: the one place where a move is validated and its joint target chosen.

- A joint target: within the joint limits, then the straight joint-space path from the current state
  checked as a motion would run it (`pathcheck.check_states`: subdivided, the robot's clearance kept).
- A pose target (end-effector position, optional orientation): an IK solution from the current state
  first; when its path collides, further IK solutions from other start configurations (up to
  `IK_ALTERNATIVES`, seeded from the target so the answer is reproducible) until one has a free path.
- When no straight path is free (to the joint target, or to any IK solution), a detour: RRT-Connect
  around what blocks the way to the (first) target, every segment checked like a path (`detour.py`).

The verdict names every check it made (`checks.ik`, `checks.limits`, `checks.path`) and, when invalid,
the reasons in words. A valid plan carries the timed path it checked (`Plan.path`, timed by
`trajectory.py` as the request asks): that path is what a move runs, never planned again. World
coordinates (m, rad); the state of the world is not changed. A plan is a long job of the world's thread
(`world_thread.py`): it reaches checkpoints between and inside its searches, where it may be cancelled
(`Cancelled`) and where other requests' short jobs run.
"""

from __future__ import annotations

import hashlib
import itertools
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import Unreachable
from robwot_sim.limits import DEFAULT_ACCELERATION, DEFAULT_DT, DEFAULT_SPEED, DEFAULT_TCP_SPEED
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.sim.detour import BUDGET as DETOUR_BUDGET
from robwot_sim.sim.lin import circ_path, lin_path
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.trajectory import densified, turning
from robwot_sim.sim.types import Contact
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import checkpoint

#: IK solutions tried from other start configurations when the first one's path collides
IK_ALTERNATIVES = 8


@dataclass(frozen=True)
class Goal:
    """What a motion reaches, as parsed where its request enters (``rpc/``): joints (``target``, PTP only)
    or an end-effector pose (``position`` m; ``orientation`` ``[x, y, z, w]`` normalised, None: any for a
    PTP, kept for a LIN or CIRC), by ``motion`` ``ptp``, ``lin`` or ``circ`` (``via``: a point of the arc,
    a CIRC's only)."""

    motion: str
    target: tuple[float, ...] | None = None
    position: tuple[float, ...] | None = None
    orientation: tuple[float, ...] | None = None
    via: tuple[float, ...] | None = None


@dataclass(frozen=True)
class Timing:
    """How a plan's path is timed: ``speed`` x the joint velocity limits, ``acceleration`` x the
    acceleration limits (and the end effector's along a LIN or CIRC), the end effector at ``tcp_speed``
    (m/s) along a LIN or CIRC, states ``dt`` (s) apart; within the contract's ranges. A detour runs as
    ``detour`` says (the contract's ``DetourRun``): ``smooth`` one motion through its waypoints, ``stops``
    at rest where its path turns."""

    speed: float = DEFAULT_SPEED
    dt: float = DEFAULT_DT
    acceleration: float = DEFAULT_ACCELERATION
    tcp_speed: float = DEFAULT_TCP_SPEED
    detour: str = "smooth"


@dataclass(frozen=True)
class Plan:
    """The verdict on a target and, when valid, the joint target a move runs to along ``path``."""

    valid: bool
    target: tuple[float, ...] | None
    reasons: tuple[str, ...] = ()
    checks: dict[str, Any] = field(default_factory=dict)
    #: waypoints before ``target`` (a detour, or a LIN's or CIRC's samples); empty for a straight path
    via: tuple[tuple[float, ...], ...] = ()
    #: a LIN or CIRC: the end effector's distance along its curve (m) at the start, each waypoint and the
    #: target; the motion runs through the waypoints without stopping
    arc: tuple[float, ...] = ()
    #: a valid plan's timed path, from the state the plan was made in, checked in this world: what a move
    #: of the plan runs. None when refused, or for a LIN or CIRC of a program left untimed (``timed``
    #: False): it is timed with the steps it blends into
    path: TimedPath | None = field(default=None, compare=False, repr=False)

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"valid": self.valid, "reasons": list(self.reasons), "checks": self.checks}
        if self.target is not None:
            out["target"] = list(self.target)
        if self.via:
            out["via"] = [list(w) for w in self.via]
        return out


def _fmt(v: float) -> str:
    return f"{v:.4f}" if abs(v) >= 1e-3 or v == 0 else f"{v:.2e}"


def contact_words(contacts: Sequence[Contact]) -> str:
    if not contacts:
        return ""
    c = contacts[0]

    def side(s: Any) -> str:
        return f"{s.body}/{s.link}" if s.link else str(s.body)

    return f" ({side(c.a)} touches {side(c.b)}, depth {_fmt(c.depth)} m)"


def _limit_violations(model: RobotModel, q: Sequence[float]) -> list[dict[str, Any]]:
    joints = {j.name: j for j in model.joints}
    out = []
    for name, value in zip(model.controllable, q, strict=True):
        j = joints[name]
        if value < j.lower - 1e-9 or value > j.upper + 1e-9:
            out.append({"joint": name, "value": float(value), "lower": j.lower, "upper": j.upper})
    return out


def _path(world: World, robot: str, q: Sequence[float],
          timing: Timing) -> tuple[bool, list[Contact], TimedPath, tuple[Contact, ...]]:
    """The straight path from the current state to ``q``, timed and checked (``World.check_path``),
    with the timed path it checked and the contacts of the current state (none unless it collides)."""
    path = world.plan_motion(robot, q, None, timing.speed, timing.dt, acceleration=timing.acceleration)
    report = world.check_states(robot, path)
    contacts = list(report.first_collision.contacts) if report.first_collision is not None else []
    return report.collision_free, contacts, path, report.start_contacts


def start_words(start: Sequence[Contact], contacts: Sequence[Contact]) -> str:
    """Why a path from a colliding current state is refused: that state's contacts first, then where the
    path stopped leaving them (``exit_contact.py``)."""
    return (f"the current state already collides{contact_words(start)}: a path may leave it only while the "
            f"contact recedes until free, and this one does not{contact_words(contacts)}")


def path_check(clearance: float, ok: bool, contacts: Sequence[Contact], planned: str = "straight",
                detour: str | None = None) -> dict[str, Any]:
    out = {"ok": ok, "planned": planned, "clearance": clearance, "contacts": [c.to_json() for c in contacts]}
    return out if detour is None else {**out, "detour": detour}


#: what a refusal adds when the detour search (``PlanChecks.path.detour``) found nothing
_NO_DETOUR = f"; no detour around it found within {DETOUR_BUDGET:g} s (RRT-Connect)"


def _detour(world: World, robot: str, target: Sequence[float], checks: dict[str, Any],
            timing: Timing) -> Plan | None:
    """A valid plan around what blocks the straight path to ``target``, or None. Its timed path is one
    motion through the waypoints (``_through``)."""
    waypoints = world.detour(robot, target)
    if waypoints is None:
        return None
    start = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
    timed = _through(world, robot, [start, *(np.asarray(w, dtype=np.float64) for w in waypoints)], timing)
    path = path_check(world.robot_model(robot).clearance, True, [], "detour", "found")
    return Plan(True, tuple(waypoints[-1]), (), {**checks, "path": path}, tuple(waypoints[:-1]), path=timed)


def _through(world: World, robot: str, corners: list[npt.NDArray[np.float64]], timing: Timing) -> TimedPath:
    """A detour's motion: the straight segments the search checked, at rest only where the path turns,
    or (``smooth``) one curve along them (the spline through its straight stretches, densely sampled, so
    it slows only where the path turns) when that is faster and, checked again as it would run, touches
    nothing."""
    turns = turning(corners)
    legs = world.plan_motion(robot, turns[-1], turns[0], timing.speed, timing.dt, turns[1:-1],
                             acceleration=timing.acceleration)
    if timing.detour == "smooth" and len(turns) > 2:
        points = densified(corners)
        curve = world.plan_motion(robot, points[-1], points[0], timing.speed, timing.dt, points[1:-1],
                                  acceleration=timing.acceleration, arc=[0.0] * len(points), tcp_speed=None)
        # a curve through few, sharp turns may take longer than stopping at them: the faster one runs
        if curve.duration < legs.duration and world.check_states(robot, curve).collision_free:
            return curve
    return legs


def plan(world: World, robot: str, goal: Goal, timing: Timing, *, timed: bool = True) -> Plan:
    """The verdict on ``goal``, its path timed by ``timing`` (``plan_joints``, ``plan_pose`` or
    ``plan_lin``; ``timed`` False: a LIN's or CIRC's path is left to the caller to time)."""
    if goal.target is not None:
        return plan_joints(world, robot, goal.target, timing.speed, timing.dt,
                           acceleration=timing.acceleration, detour=timing.detour)
    assert goal.position is not None  # a goal has a target or a position (``Goal``)
    if goal.motion == "ptp":
        return plan_pose(world, robot, goal.position, goal.orientation, timing.speed, timing.dt,
                         acceleration=timing.acceleration, detour=timing.detour)
    return plan_lin(world, robot, goal.position, goal.orientation, goal.via, speed=timing.speed,
                    dt=timing.dt, acceleration=timing.acceleration, tcp_speed=timing.tcp_speed, timed=timed)


def plan_joints(world: World, robot: str, target: Sequence[float], speed: float = DEFAULT_SPEED,
                dt: float = DEFAULT_DT, *, acceleration: float = DEFAULT_ACCELERATION,
                detour: str = "smooth") -> Plan:
    """The verdict on a joint target (a detour run as ``detour`` says: ``Timing``)."""
    timing = Timing(speed, dt, acceleration, detour=detour)
    model = world.robot_model(robot)
    violations = _limit_violations(model, target)
    limits: dict[str, Any] = {"ok": not violations}
    if violations:
        limits["violations"] = violations
    checks: dict[str, Any] = {"limits": limits}
    if violations:
        reasons = tuple(f"joint {v['joint']} = {_fmt(v['value'])} outside its limits "
                        f"[{_fmt(v['lower'])}, {_fmt(v['upper'])}]" for v in violations)
        return Plan(False, None, reasons, checks)
    ok, contacts, path, start = _path(world, robot, target, timing)
    if ok:
        checks["path"] = path_check(model.clearance, True, [])
        return Plan(True, tuple(float(v) for v in target), (), checks, path=path)
    at_target = world.check_collision(robot, target)
    if start and at_target.collision_free:
        # no detour starts in contact: the search needs a free start
        checks["path"] = path_check(model.clearance, False, contacts, detour="not searched")
        return Plan(False, tuple(float(v) for v in target), (start_words(start, contacts),), checks)
    if at_target.collision_free:
        around = _detour(world, robot, target, checks, timing)
        if around is not None:
            return around
        searched = "not found"
        reason = f"the straight path to the target collides{contact_words(contacts)}{_NO_DETOUR}"
    else:
        searched = "not searched"
        contacts = list(at_target.contacts)
        reason = f"the target configuration itself collides{contact_words(contacts)}: no path reaches it"
    checks["path"] = path_check(model.clearance, False, contacts, detour=searched)
    return Plan(False, tuple(float(v) for v in target), (reason,), checks)


def _alternative_seeds(model: RobotModel, position: Sequence[float], orientation: Sequence[float] | None,
                       count: int) -> Iterator[list[float]]:
    """`count` start configurations within the limits, the same for the same target, drawn as asked (most
    targets need none)."""
    key = struct.pack(f"{3 + len(orientation or [])}d", *position, *(orientation or []))
    rng = np.random.default_rng(int.from_bytes(hashlib.sha256(key).digest()[:8], "little"))
    lower, upper = model.limits()
    for _ in range(count):
        yield list(rng.uniform(lower, upper))


def plan_pose(world: World, robot: str, position: Sequence[float], orientation: Sequence[float] | None,
              speed: float = DEFAULT_SPEED, dt: float = DEFAULT_DT, alternatives: int = IK_ALTERNATIVES, *,
              acceleration: float = DEFAULT_ACCELERATION, detour: str = "smooth") -> Plan:
    """The verdict on an end-effector pose: the first IK solution whose path is free (a detour run as
    ``detour`` says: ``Timing``)."""
    timing = Timing(speed, dt, acceleration, detour=detour)
    model = world.robot_model(robot)
    where = f"({', '.join(_fmt(v) for v in position)}) m"
    seeds = itertools.chain([None], _alternative_seeds(model, position, orientation, alternatives))
    first: tuple[tuple[float, ...], float, list[Contact]] | None = None
    start: tuple[Contact, ...] = ()
    #: an IK solution that reaches the target but whose configuration collides
    reached_colliding: Sequence[float] | None = None
    tried = 0
    best_error = float("inf")
    for seed in seeds:
        checkpoint()  # between solutions the world is consistent (world_thread.py)
        tried += 1
        try:
            ik = world.ik(robot, position, orientation, seed=seed, collision_free=True)
        except Unreachable as exc:
            best_error = min(best_error, float(exc.data.get("positionError", float("inf"))))
            if exc.data.get("beyondReach"):
                reason = f"target {where} is {_fmt(best_error)} m beyond the robot's reach"
                ik_check = {"ok": False, "positionError": best_error, "solutions": tried}
                return Plan(False, None, (reason,), {"ik": ik_check})
            if seed is None:
                # the solver's own restarts found nothing within tolerance: other seeds will not either
                break
            continue
        best_error = min(best_error, ik.position_error)
        if not ik.collision_free:
            reached_colliding = reached_colliding if reached_colliding is not None else ik.positions
            continue
        ok, contacts, checked, start = _path(world, robot, ik.positions, timing)
        if first is None:
            first = (ik.positions, ik.position_error, contacts)
        if ok:
            checks = {"ik": {"ok": True, "positionError": ik.position_error, "solutions": tried},
                      "limits": {"ok": True}, "path": path_check(model.clearance, True, [])}
            return Plan(True, ik.positions, (), checks, path=checked)
    if first is None:
        error = best_error if best_error != float("inf") else -1.0
        ik_check = {"ok": False, "positionError": error, "solutions": tried}
        if reached_colliding is not None:
            # IK reached the target: what stands in the way is a collision at the target itself, so no
            # path can reach it (the path check names what touches there; no detour is searched)
            touching = world.check_collision(robot, reached_colliding).contacts
            reason = (f"every IK solution reaching {where} ({tried} tried, within {_fmt(error)} m) collides "
                      f"at the target{contact_words(touching)}")
            path = path_check(model.clearance, False, touching, detour="not searched")
            return Plan(False, None, (reason,), {"ik": ik_check, "path": path})
        elif error >= 0:
            reason = f"IK found no solution within 0.001 m of {where} (closest {_fmt(error)} m away)"
        else:
            reason = f"target {where} is not reachable by IK"
        return Plan(False, None, (reason,), {"ik": ik_check})
    positions, error, contacts = first
    checks = {"ik": {"ok": True, "positionError": error, "solutions": tried}, "limits": {"ok": True}}
    if start:
        checks["path"] = path_check(model.clearance, False, contacts, detour="not searched")
        reason = f"to every IK solution tried ({tried}): {start_words(start, contacts)}"
        return Plan(False, positions, (reason,), checks)
    around = _detour(world, robot, positions, checks, timing)
    if around is not None:
        return around
    checks["path"] = path_check(model.clearance, False, contacts, detour="not found")
    reason = (f"the straight path to every IK solution tried ({tried}) collides{contact_words(contacts)}"
              f"{_NO_DETOUR} to the first")
    return Plan(False, positions, (reason,), checks)


def plan_lin(world: World, robot: str, position: Sequence[float],
             orientation: Sequence[float] | None, via: Sequence[float] | None = None, *,
             speed: float = DEFAULT_SPEED, dt: float = DEFAULT_DT, acceleration: float = DEFAULT_ACCELERATION,
             tcp_speed: float = DEFAULT_TCP_SPEED, timed: bool = True) -> Plan:
    """The verdict on a LIN to a pose, or a CIRC through ``via`` (``lin.py``): the end effector on the
    straight line or the arc, every sample within the joint limits, the joints able to keep the end
    effector at ``tcp_speed`` (m/s) within their velocity limits x ``speed`` (near a singularity they
    are not), every segment collision-free, and the timed motion through the samples too (``time_lin``;
    with ``timed`` False left to the caller: a program's step blended into others); the waypoints as
    ``via``."""
    model = world.robot_model(robot)
    kind = "lin" if via is None else "circ"
    path = lin_path(world, robot, position, orientation) if via is None else circ_path(
        world, robot, via, position, orientation)
    if path.reason is not None:
        checks: dict[str, Any] = {"limits": {"ok": True}}
        why = f"{path.reason}{contact_words(path.contacts)}"
        if path.contacts:
            checks["path"] = path_check(model.clearance, False, path.contacts, kind)
            here = world.check_collision(robot)
            if not here.collision_free:  # a LIN or CIRC never leaves a contact: a joint move can
                why = (f"the current state already collides{contact_words(here.contacts)} (a joint or PTP "
                       f"move may leave it): {why}")
        return Plan(False, None, (f"{kind.upper()} refused: {why}",), checks)
    for i, q in enumerate(path.waypoints):
        violations = _limit_violations(model, [float(v) for v in q])
        if violations:
            v = violations[0]
            reason = (f"{kind.upper()} refused: joint {v['joint']} = {_fmt(v['value'])} leaves its limits "
                      f"[{_fmt(v['lower'])}, {_fmt(v['upper'])}] at waypoint {i} of "
                      f"{len(path.waypoints) - 1}")
            return Plan(False, None, (reason,), {"limits": {"ok": False, "violations": violations}})
    too_fast = _joint_rate_violation(world, robot, path.waypoints, path.arc, speed, tcp_speed)
    if too_fast is not None:
        return Plan(False, None, (f"{kind.upper()} refused: {too_fast}",), {"limits": {"ok": True}})
    checks = {"ik": {"ok": True, "positionError": 0.0, "solutions": len(path.waypoints) - 1},
              "limits": {"ok": True}, "path": path_check(model.clearance, True, [], kind)}
    target = tuple(float(v) for v in path.waypoints[-1])
    waypoints = tuple(tuple(float(v) for v in w) for w in path.waypoints[1:-1])
    samples = Plan(True, target, (), checks, waypoints, tuple(path.arc))
    return time_lin(world, robot, samples, Timing(speed, dt, acceleration, tcp_speed)) if timed else samples


def time_lin(world: World, robot: str, plan: Plan, timing: Timing,
             start: Sequence[float] | None = None) -> Plan:
    """``plan`` (a LIN's or CIRC's samples, from ``start``; default: the current state) with its timed
    path when that passes the path check, else refused naming the bodies: the states of a LIN or CIRC lie
    on the spline through its checked samples, not on the chords between them, so every state a motion
    runs is checked in this world."""
    assert plan.target is not None
    path = world.plan_motion(robot, plan.target, start, timing.speed, timing.dt, plan.via,
                             acceleration=timing.acceleration, arc=plan.arc, tcp_speed=timing.tcp_speed)
    report = world.check_states(robot, path)
    if report.collision_free or report.first_collision is None:
        return replace(plan, path=path)
    kind = str(plan.checks["path"]["planned"])
    contacts = report.first_collision.contacts
    why = (start_words(report.start_contacts, contacts) if report.start_contacts else
           f"the timed path between its checked samples collides{contact_words(contacts)}")
    reason = f"{kind.upper()} refused: {why}"
    checks = {**plan.checks, "path": path_check(world.robot_model(robot).clearance, False, contacts, kind)}
    return Plan(False, None, (reason,), checks)


def _joint_rate_violation(world: World, robot: str, waypoints: Sequence[Any], arc: Sequence[float],
                          speed: float, tcp_speed: float) -> str | None:
    """Why the joints cannot keep the end effector at ``tcp_speed`` between two waypoints (the first such
    joint and place), or None. Joint i turns dq_i per metre of curve, so it needs |dq_i/ds| x tcp_speed."""
    model = world.robot_model(robot)
    limits = model.velocity_limits() * speed
    q, s = np.asarray(waypoints, dtype=np.float64), np.asarray(arc, dtype=np.float64)
    ds = np.diff(s)
    moving = ds > 0
    if not moving.any():
        return None
    rates = np.abs(np.diff(q, axis=0))[moving] / ds[moving, None] * tcp_speed
    over = rates / limits[None, :]
    k, j = np.unravel_index(int(np.argmax(over)), over.shape)
    if over[k, j] <= 1.0:
        return None
    at = float(s[1:][moving][k])
    return (f"joint {model.controllable[j]} would need {rates[k, j]:.2f} rad/s (limit {limits[j]:.2f} x "
            f"speed) to keep the end effector at {tcp_speed:g} m/s {1000 * at:.0f} mm along the path: a "
            f"singularity or near one; lower tcpSpeed or move around it")
