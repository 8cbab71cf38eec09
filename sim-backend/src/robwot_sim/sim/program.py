"""A program: steps planned one after the other, each from where the previous one ends, by the same
planners as single moves (``planner.py``: PTP with its detours, LIN, CIRC). The robot's true state is
untouched: the steps are planned in ``Scene.hypothetical`` states (``planning_scene.py``).

Each step is planned and timed as a move of the same step is (``planner.plan``: the joint velocity limits x
its ``speed``, acceleration limits x its ``acceleration``, a LIN's or CIRC's ``tcpSpeed``; the plan carries
its checked, timed path), at rest where it ends; steps joined by blends are timed again as one motion.
The program's path is those states one after the other, one per ``dt``: its cycle time is the time a run
of it takes at real time (``program.run`` runs exactly these states), and the trajectory a client gets is
that path sampled at ``rate`` (at most ``MAX_TRAJECTORY_SAMPLES`` samples: a longer program at a lower
rate). The states are computed when asked for (``timed.py``): a slow program costs no more to plan than a
fast one, and no more memory.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robwot_sim.errors import PlanBudget, SimError
from robwot_sim.limits import MAX_TRAJECTORY_SAMPLES
from robwot_sim.sim.planner import Goal, Plan, Timing, contact_words, plan, time_lin
from robwot_sim.sim.timed import Curve, Straight, TimedPath
from robwot_sim.sim.trajectory import Along, densified
from robwot_sim.sim.types import FloatArray
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import checkpoint

#: the steps where the robot's gripper acts (``gripper.close`` / ``gripper.open``) instead of moving
GRIPS = ("grip", "release")
#: points of the Bezier curve that rounds a junction
BLEND_POINTS = 24


@dataclass
class ProgramPlan:
    """The report (``ProgramPlan`` of the contract) and, when every step passes, what a run runs."""

    report: dict[str, Any]
    #: the joint states of the whole program, one per ``dt`` (None when a step is refused)
    path: TimedPath | None = None
    #: index in ``path`` of each step's first state (its start: the previous step's end)
    starts: list[int] = field(default_factory=list)
    #: the grip and release steps: the index in ``path`` of the first state after the gripper acted, and
    #: the step's motion (``grip``, ``release``): a run makes the gripper act just before that state
    grips: list[tuple[int, str]] = field(default_factory=list)


@dataclass(frozen=True)
class ProgramStep:
    """One step as parsed where the request enters (``rpc/``, the contract's defaults filled in): its goal,
    how it is timed (the program's ``dt`` aside) and its blend radius (m)."""

    goal: Goal
    speed: float
    acceleration: float
    tcp_speed: float
    blend: float

    def timing(self, dt: float) -> Timing:
        return Timing(self.speed, dt, self.acceleration, self.tcp_speed)


@dataclass
class _Step:
    """A planned step: the step, its plan and the joint state it starts from."""

    step: ProgramStep
    plan: Plan
    start: FloatArray

    @property
    def tcp_speed(self) -> float | None:
        """A LIN's or CIRC's end effector speed (m/s); None for a PTP."""
        return None if self.step.goal.motion == "ptp" else self.step.tcp_speed

    @property
    def blend(self) -> float:
        return self.step.blend


def _detour(step: _Step) -> bool:
    return bool(step.plan.checks.get("path", {}).get("planned") == "detour")


def _points(step: _Step) -> list[FloatArray]:
    """The step's joint path as points: a LIN's or CIRC's samples, or each straight segment of a PTP
    (detour legs included) split so no joint turns more than ``CURVE_POINT_STEP`` between two points."""
    assert step.plan.target is not None
    corners = [step.start, *(np.asarray(w, dtype=np.float64) for w in step.plan.via),
               np.asarray(step.plan.target, dtype=np.float64)]
    return corners if step.plan.arc else densified(corners)


def _first_state_of(states: TimedPath, owners: Sequence[int], k: int) -> int:
    """The first state of a blended group's motion that belongs to step ``k``: each state belongs to the
    step of its nearest point along the path (the points are in order, their owners non-decreasing)."""
    piece = states.pieces[0]
    if not isinstance(piece, Curve):  # the group's points all coincide: one state
        return 0
    p = next(i for i, owner in enumerate(owners) if owner >= k)
    boundary = 0.5 * float(piece.knots[p - 1] + piece.knots[p])  # nearer to p from here on
    return min(piece.steps, math.ceil(piece.index_of(boundary) - 1e-9))


def _along(group: list[_Step], owners: Sequence[int]) -> Along:
    """Each point's limits: those of the step it belongs to (a junction's Bezier: the incoming step's over
    its first half, the outgoing one's over the second; between two points the smaller of both holds). A
    PTP's end effector is not limited: a LIN's ``tcpSpeed`` holds on the LIN and its half of the blends."""
    return Along([group[i].step.speed for i in owners], [group[i].step.acceleration for i in owners],
                 [group[i].tcp_speed for i in owners])


def _blend_group(world: World, robot: str, group: list[_Step],
                 dt: float) -> tuple[TimedPath | None, list[int], str | None, int]:
    """One motion through the steps of ``group`` that rounds each junction within the blend radius of the
    step ending there: the points of the incoming step closer to the junction's TCP than its radius, and of
    the outgoing one, are replaced by the quadratic Bezier (joint space) from the last point outside on one
    side, through the junction, to the first point outside on the other (at most half of either step). The
    whole is timed by ``plan_motion`` along its points (TOPP-RA; each step at its own limits, ``_along``)
    and checked again. Returns the states, the index where each step starts, and on a contact the reason
    and the step whose blend (or path) touches."""
    paths = [_points(st) for st in group]
    tcp = [np.array([world.fk(robot, q).position for q in pts]) for pts in paths]
    points: list[FloatArray] = list(paths[0])
    # the TCP position of each point, kept beside it: the arc length needs them all
    where: list[FloatArray] = list(tcp[0])
    owners: list[int] = [0] * len(points)
    for k in range(1, len(group)):
        radius = group[k - 1].blend
        corner = tcp[k - 1][-1]
        # incoming: drop the points inside the radius (keep at least the first half of the step)
        n_in = len(paths[k - 1])
        keep = n_in - 1
        while keep > n_in // 2 and np.linalg.norm(tcp[k - 1][keep - 1] - corner) < radius:
            keep -= 1
        drop = (n_in - 1) - keep  # points removed from the end of the incoming step (the junction included)
        for kept in (points, where, owners):
            del kept[len(kept) - drop - 1:]
        qa = points[-1]
        # outgoing: the first point outside the radius (at most half the step)
        n_out = len(paths[k])
        first = 1
        while first < n_out // 2 and np.linalg.norm(tcp[k][first] - corner) < radius:
            first += 1
        qb, qj = paths[k][first], paths[k][0]
        bezier = [(1 - t) ** 2 * qa + 2 * t * (1 - t) * qj + t**2 * qb
                  for t in np.linspace(0.0, 1.0, BLEND_POINTS)[1:-1]]
        points.extend(bezier)
        where.extend(np.asarray(world.fk(robot, q).position) for q in bezier)
        owners.extend([k - 1] * (len(bezier) // 2) + [k] * (len(bezier) - len(bezier) // 2))
        points.extend(paths[k][first:])
        where.extend(tcp[k][first:])
        owners.extend([k] * (n_out - first))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(np.array(where), axis=0), axis=1))])
    states = world.plan_motion(robot, points[-1], points[0], group[0].step.speed, dt, points[1:-1],
                               arc=arc.tolist(), along=_along(group, owners),
                               tcp=[list(p) for p in where])
    starts = [0] + [_first_state_of(states, owners, k) for k in range(1, len(group))]
    report = world.check_states(robot, states)
    if report.collision_free or report.first_collision is None:
        return states, starts, None, 0
    hit = round(report.first_collision.time / dt)
    k = max(i for i, s0 in enumerate(starts) if s0 <= hit)
    return None, starts, contact_words(report.first_collision.contacts), k


def _plan_steps(world: World, robot: str, steps: Sequence[ProgramStep], dt: float,
                verdicts: list[dict[str, Any]], start: FloatArray | None = None,
                total: int | None = None) -> tuple[list[_Step], int | None]:
    """Each step planned from where the previous one ends (the first from ``start``, default the robot's
    state), up to the first refused one (its index, or None); a verdict per step planned appended to
    ``verdicts``, numbered after those already there (a program's later segment: ``total`` its steps)."""
    planned: list[_Step] = []
    offset = len(verdicts)
    with world.hypothetical(robot):
        q = np.asarray(world.get_joint_positions(robot) if start is None else start, dtype=np.float64)
        for k, step in enumerate(steps):
            with _naming(offset + k, total or len(steps)):
                checkpoint()
                world.place(robot, q)
                # a LIN or CIRC that may be blended is timed with its group, not alone (``plan_program``)
                blends = (step.blend > 0 and k + 1 < len(steps)) or (k > 0 and steps[k - 1].blend > 0)
                verdict = plan(world, robot, step.goal, step.timing(dt), timed=not blends)
            verdicts.append({"step": offset + k, "ok": verdict.valid, "reasons": list(verdict.reasons),
                             "checks": verdict.checks, "duration": 0.0})
            if not verdict.valid or verdict.target is None:
                return planned, k
            planned.append(_Step(step, verdict, q))
            q = np.asarray(verdict.target, dtype=np.float64)
    return planned, None


@contextlib.contextmanager
def _naming(step: int, steps: int) -> Iterator[None]:
    """A plan's budget running out here names the program's step."""
    try:
        yield
    except PlanBudget as exc:
        raise exc.at_step(step, steps) from None


def _sampled(trajectory: TimedPath, rate: float) -> tuple[FloatArray, int]:
    """The states at about ``rate`` Hz (the last one always included), at most ``MAX_TRAJECTORY_SAMPLES``
    of them (a lower rate for a longer path), and the stride between them (in states)."""
    n = len(trajectory)
    stride = max(1, round(1.0 / (rate * trajectory.dt)), math.ceil((n - 1) / (MAX_TRAJECTORY_SAMPLES - 2)))
    picked = trajectory.rows(0, n, stride)
    if (n - 1) % stride:
        picked = np.vstack([picked, trajectory.last])
    return picked, stride


def plan_program(world: World, robot: str, steps: Sequence[ProgramStep], dt: float,
                 rate: float) -> ProgramPlan:
    """Per-step verdicts (from the first step to the first refused one), the index of the first refused
    step (None when all pass), the cycle time (s) and the joint trajectory sampled at ``rate`` (Hz).
    `PlanBudget` names the step being planned when the job's budget runs out. A program with grip or
    release steps is planned in segments between them, the gripper acting between two in a trial of the
    world (``Grippers.trial``): every later step is checked with what the gripper then holds."""
    names = list(world.robot_model(robot).controllable)
    timeline = _Timeline(dt)
    gripping = any(st.goal.motion in GRIPS for st in steps)
    with world.grippers.trial(robot) if gripping else contextlib.nullcontext():
        q: FloatArray | None = None
        k = 0
        while k < len(steps) and timeline.failing is None:
            end = next((i for i in range(k, len(steps)) if steps[i].goal.motion in GRIPS), len(steps))
            planned, failing = _plan_steps(world, robot, steps[k:end], dt, timeline.verdicts, q, len(steps))
            timeline.time(world, robot, planned, k, len(steps))
            if failing is not None and timeline.failing is None:
                timeline.failing = k + failing
            if timeline.failing is not None or end == len(steps):
                break
            if planned:
                q = np.asarray(planned[-1].plan.target, dtype=np.float64)
            elif q is None:
                q = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
            q = timeline.grip(world, robot, end, steps[end].goal.motion, q)
            k = end + 1
    trajectory = TimedPath.join(timeline.segments) if timeline.segments else TimedPath.still(
        np.asarray(world.get_joint_positions(robot), dtype=np.float64), dt)
    picked, stride = _sampled(trajectory, rate)
    verdicts, first_failing = timeline.verdicts, timeline.failing
    cycle = float(sum(v["duration"] for v in verdicts))
    report = {"valid": first_failing is None, "firstFailingStep": first_failing, "cycleTime": cycle,
              "steps": verdicts,
              "trajectory": {"rate": 1.0 / (stride * dt), "dt": stride * dt, "names": names,
                             "positions": picked.tolist()}}
    if first_failing is not None:
        return ProgramPlan(report)
    return ProgramPlan(report, trajectory, timeline.starts, timeline.grips)


class _Timeline:
    """A program's timed path being built: its segments, each step's first state, the verdicts, where the
    gripper acts, the first refused step."""

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.segments: list[TimedPath] = []
        self.starts: list[int] = []
        self.grips: list[tuple[int, str]] = []
        self.verdicts: list[dict[str, Any]] = []
        self.failing: int | None = None
        self.done = 0  # states so far, the first aside

    def _add(self, states: TimedPath) -> None:
        self.segments.append(states)
        self.done += len(states) - 1

    def time(self, world: World, robot: str, planned: list[_Step], offset: int, total: int) -> None:
        """The planned steps of one segment (program steps ``offset`` on) timed in groups joined by
        blends (``_time_group``); a group that fails ends the program there."""
        k = 0
        while k < len(planned):
            # a group: steps joined by blends (the last step's blend has nothing to go on to; a detour's
            # corners are stops, so a step planned as a detour is neither blended into nor out of)
            end = k
            while (end + 1 < len(planned) and planned[end].blend > 0 and not _detour(planned[end])
                   and not _detour(planned[end + 1])):
                end += 1
            with _naming(offset + k, total):
                checkpoint()
                states, group_starts, failed = _time_group(world, robot, planned, (k, end), offset,
                                                           self.verdicts, self.dt)
            if failed is not None:
                # the steps of the group before the failing one keep their verdicts, without a duration
                del self.verdicts[offset + k + failed + 1:]
                self.failing = offset + k + failed
                return
            assert states is not None
            bounds = [*group_starts, len(states) - 1]
            for i, st in enumerate(planned[k:end + 1]):
                v = self.verdicts[offset + k + i]
                v["duration"] = (bounds[i + 1] - bounds[i]) * self.dt
                v["planned"] = st.plan.checks.get("path", {}).get("planned", "straight")
                v["target"] = [float(x) for x in st.plan.target or ()]
                if st.blend > 0 and i < end - k:
                    v["blended"] = True
                self.starts.append(self.done + bounds[i])
            self._add(states)
            k = end + 1

    def grip(self, world: World, robot: str, k: int, motion: str, q: FloatArray) -> FloatArray:
        """Program step ``k``, a grip or release, where the robot stands at ``q``: the gripper acts (in the
        planning's trial of the world), then a still stretch of its time with the fingers where it left
        them; the joints after it. An object it cannot let go (``E_OVERLAP``) refuses the step."""
        world.place(robot, q)
        try:
            out = world.grippers.close(robot) if motion == "grip" else world.grippers.open(robot)
        except SimError as e:
            self.verdicts.append({"step": k, "ok": False, "reasons": [e.message], "checks": {},
                                  "duration": 0.0})
            self.failing = k
            return q
        after = np.asarray(world.get_joint_positions(robot), dtype=np.float64)
        n = max(1, round(float(out["gripper"]["time"]) / self.dt))
        self.starts.append(self.done)
        self.grips.append((self.done + 1, motion))
        held = TimedPath([Straight(after, after, n * self.dt, 1.0, 1.0, n)], self.dt)
        self._add(TimedPath.join([TimedPath.still(q, self.dt), held]))
        self.verdicts.append({"step": k, "ok": True, "reasons": [], "checks": {}, "duration": n * self.dt,
                              "planned": motion, "target": [float(x) for x in after],
                              "holding": out["holding"]})
        return after


def _time_group(world: World, robot: str, planned: list[_Step], span: tuple[int, int], offset: int,
                verdicts: list[dict[str, Any]], dt: float) -> tuple[TimedPath | None, list[int], int | None]:
    """The states of steps ``span`` (first, last) of a segment (program steps from ``offset``) joined by
    blends, where each step starts in them, and the failing step (index in the group) or None."""
    k, end = span
    group = planned[k:end + 1]
    if len(group) == 1:  # the path its plan checked
        st = group[0]
        if st.plan.path is None:  # a LIN or CIRC whose blends a detour next to it stops
            st.plan = time_lin(world, robot, st.plan, st.step.timing(dt), st.start.tolist())
            if st.plan.path is None:
                verdicts[offset + k] = {**verdicts[offset + k], "ok": False, "reasons": list(st.plan.reasons),
                                        "checks": st.plan.checks}
        return st.plan.path, [0], None if st.plan.path is not None else 0
    states, group_starts, contact, failed_at = _blend_group(world, robot, group, dt)
    if contact is None:
        return states, group_starts, None
    at = k + failed_at
    where = (f"through the end of step {offset + at} (blend radius {planned[at].blend:g} m)"
             if planned[at].blend > 0 and at < end else f"in step {offset + at}")
    reason = f"the blended motion of steps {offset + k} to {offset + end} collides {where}{contact}"
    verdicts[offset + at] = {**verdicts[offset + at], "ok": False, "checks": {}, "reasons": [reason]}
    return states, group_starts, failed_at
