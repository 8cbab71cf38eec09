"""Executes robot motions from the asyncio loop: one operation per move — plan, then run — streamed.

`robot.move` takes the robot (busy from here: `E_BUSY` for a second move, `stop` ends it), plans the
target (`sim/planner.py`: limits, IK solutions, a collision-free path; `Rejected` when none) and runs the
timed path the plan carries (`Plan.path`, timed by `sim/trajectory.py`; a program's states come from
`sim/program.py`), never planned again: for every state it waits until its wall-clock due time
(`t0 + t_sim / realtime`; with realtime 0 it only yields to the loop) and teleports the robot there; a
run that fell behind its clock (a loaded machine) takes the states due by now in one job of the world's
thread, each still checked, so it catches up and its wall time stays its simulated duration.
The plan checked this very path; once anything else in the
world changes during the motion (an obstacle added or moved, another robot moving: `World.others_stamp`)
every further step is checked again (`World.check_step`: subdivided so no point travels more than twice
the clearance unchecked, other bodies kept the clearance away).
A colliding step ends the motion at the last collision-free state (`status: "collision"`, a
`robot.collision` notification). `robot.state` notifications go out at every step whose simulated time
crosses a 1/60 s boundary, plus the final state (`moving: false`). One motion per robot: a second
`move` raises `Busy`; `stop` ends the current motion at its last reached state (`status: "stopped"`)
and returns once it has ended, so a new `move` may follow at once.

The loop itself never calls PyBullet: the plan is a long job of the world's thread (`world_thread.py`),
each step a short one, which runs even during another robot's plan, at that plan's next checkpoint.
A stop during the plan cancels it at its next checkpoint (the move answers `stopped`, nothing moved),
so a stop, like a ping, is answered without waiting for a search to end. The stamp of the world is
taken when the plan starts: what changes while it runs (other robots' steps at its checkpoints) makes
every step of this motion checked again.
"""

from __future__ import annotations

import asyncio
import bisect
import contextlib
import functools
import math
import threading
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, TypeVar

import numpy as np

from robwot_sim.errors import Busy, Rejected
from robwot_sim.limits import DEFAULT_DT, PLAN_BUDGET
from robwot_sim.sim.planner import Plan
from robwot_sim.sim.program import ProgramStep, plan_program
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.types import CollisionReport, Pose
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Cancelled, Kind

Broadcast = Callable[[str, dict[str, Any]], None]
T = TypeVar("T")

STATE_PERIOD = 1.0 / 60.0
#: states of a path computed at once while it runs
RUN_CHUNK = 256
#: states a run that fell behind its simulated clock takes in one job of the world's thread
CATCH_UP = 32
#: samples per second (Hz) of the trajectory in a run program's report
PROGRAM_RATE = 50.0


class OnWorld(Protocol):
    """`Services.on_world`: run a function on the world's thread."""

    def __call__(self, fn: Callable[[], T], kind: Kind = Kind.SHORT, *, robot: str | None = None,
                 writes: bool = False, cancel: threading.Event | None = None,
                 budget: float | None = None) -> Awaitable[T]: ...


@dataclass
class _Motion:
    robot: str
    stop: asyncio.Event = field(default_factory=asyncio.Event)
    done: asyncio.Event = field(default_factory=asyncio.Event)
    #: set with ``stop``: the plan (a long world job) ends at its next checkpoint
    abort: threading.Event = field(default_factory=threading.Event)

    @property
    def stop_requested(self) -> bool:
        return self.stop.is_set()

    def request_stop(self) -> None:
        self.stop.set()
        self.abort.set()

    async def pause(self, delay: float) -> None:
        """Sleep `delay` seconds (always yielding to the loop), waking early on a stop request."""
        if delay <= 0:
            await asyncio.sleep(0)
            return
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.stop.wait(), delay)


@dataclass(frozen=True)
class _Prepared:
    """What the plan job hands to the run: the checked, timed path, the stamp of the world it was checked
    in and the clearance the motion keeps; a move's plan, or a program's step starts (index in ``path``)
    and report."""

    path: TimedPath
    stamp: tuple[int, int]
    clearance: float
    plan: Plan | None = None
    starts: tuple[int, ...] = ()
    program: dict[str, Any] | None = None
    #: a program's grip and release steps: the gripper acts just before the state of that index
    grips: tuple[tuple[int, str], ...] = ()


class MotionRunner:
    """Runs at most one motion per robot; motions of different robots run concurrently."""

    def __init__(self, world: World, broadcast: Broadcast, on_world: OnWorld) -> None:
        self._world = world
        self._broadcast = broadcast
        self._on_world = on_world
        self._active: dict[str, _Motion] = {}

    def is_moving(self, robot: str) -> bool:
        return robot in self._active

    async def stop(self, robot: str) -> bool:
        """Stop the robot's motion and wait until it has ended; True when one was running."""
        motion = self._active.get(robot)
        if motion is None:
            return False
        motion.request_stop()
        await motion.done.wait()
        return True

    async def stop_and_wait(self, robots: Sequence[str] | None = None) -> None:
        """Stop the given robots' motions (all when None) and wait until they have ended."""
        motions = [m for r, m in self._active.items() if robots is None or r in robots]
        for motion in motions:
            motion.request_stop()
        for motion in motions:
            await motion.done.wait()

    async def move(self, robot: str, planner: Callable[[], Plan], *, realtime: float = 1.0) -> dict[str, Any]:
        """Plan with `planner` and move `robot` along the plan's timed path; returns the MoveResult dict
        (with the plan). `Rejected` when the plan is not valid: nothing moved."""
        job = functools.partial(self._prepare, robot, planner)
        result = await self._perform(robot, job, realtime)
        return {k: v for k, v in result.items() if k not in ("step", "program")}

    async def run_program(self, robot: str, steps: Sequence[ProgramStep], *, realtime: float = 1.0,
                          dt: float = DEFAULT_DT) -> dict[str, Any]:
        """Plan the program (``sim/program.py``) and run its states; returns the ProgramRunResult dict.
        `Rejected` (with the program's report) when a step is refused: nothing moved."""
        job = functools.partial(self._prepare_program, robot, steps, dt)
        result = await self._perform(robot, job, realtime)
        return {"step": 0, **{k: v for k, v in result.items() if k != "plan"}}

    async def _perform(self, robot: str, job: Callable[[], _Prepared], realtime: float) -> dict[str, Any]:
        if robot in self._active:
            raise Busy(robot)
        motion = _Motion(robot)
        self._active[robot] = motion
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        try:
            try:
                prepared = await self._on_world(job, Kind.LONG, robot=robot, cancel=motion.abort,
                                                budget=PLAN_BUDGET)
            except Cancelled:  # stopped while planning: nothing moved
                q = await self._on_world(lambda: self._world.get_joint_positions(robot), robot=robot)
                return {"status": "stopped", "positions": _floats(q), "duration": 0.0,
                        "wallTime": loop.time() - t0, "contacts": []}
            result = await self._run(motion, prepared.path, realtime, prepared.stamp, prepared.clearance,
                                     prepared.starts, dict(prepared.grips))
            if prepared.program is not None:
                result["program"] = prepared.program
            if prepared.plan is not None:
                result["plan"] = prepared.plan.to_json()
            return result
        finally:
            del self._active[robot]
            motion.done.set()

    def _prepare(self, robot: str, planner: Callable[[], Plan]) -> _Prepared:
        """On the world's thread: the plan, its timed path (the one the plan checked: not planned again) and
        the clearance the motion keeps; `Rejected` when the plan is not valid. The plan checked exactly
        this path in this world: steps are checked again once anything else changes from here on (stamped
        before planning: a change during or after it counts)."""
        stamp = self._world.others_stamp(robot)
        plan = planner()
        if plan.path is None:
            raise Rejected(plan.reasons, plan.checks)
        return _Prepared(plan.path, stamp, self._world.motion_clearance(robot, plan.path.last), plan)

    def _prepare_program(self, robot: str, steps: Sequence[ProgramStep], dt: float) -> _Prepared:
        """On the world's thread: the program's plan (``plan_program``) and its states; `Rejected` with the
        report naming the first refused step. Like a move's, the states are checked again once anything
        else changes from the stamp on."""
        stamp = self._world.others_stamp(robot)
        program = plan_program(self._world, robot, steps, dt, PROGRAM_RATE)
        report = program.report
        if program.path is None:
            k = int(report["firstFailingStep"])
            failing = report["steps"][k]
            raise Rejected(tuple(f"step {k}: {r}" for r in failing["reasons"]), failing["checks"], report)
        if program.grips and self._world.others_stamp(robot)[1] == stamp[1]:
            # planned through a trial of the gripper (``Grippers.trial``), which rebuilt bodies and put
            # objects back: the world is the one checked unless another robot moved meanwhile (scene edits
            # never run during a plan, ``world_thread.py``)
            stamp = self._world.others_stamp(robot)
        # the fingers as the gripper holds them now (a grip step's states have them where it will put them)
        pin = self._world.scene.entry(robot).bound.pin
        ends = [pin(program.path[i]) for i in program.starts] + [pin(program.path.last)]
        return _Prepared(program.path, stamp, self._world.motion_clearance(robot, *ends),
                         starts=tuple(program.starts), program=report, grips=tuple(program.grips))

    def _state(self, robot: str, time: float, q: Any, pose: Pose, moving: bool,
               planned: float, step: int | None = None) -> dict[str, Any]:
        """A ``robot.state`` notification: joints and the end-effector pose at the robot's current state
        (``q``, just applied), so no client needs an FK round trip per notification; ``planned`` is the
        simulated duration of the whole path (``time / planned`` = the motion's progress)."""
        out = {"robot": robot, "time": time, "planned": planned, "positions": _floats(q), "moving": moving,
               "position": _floats(pose.position), "orientation": _floats(pose.quat_xyzw)}
        return out if step is None else {**out, "step": step}

    def _steps(self, robot: str, reached: Any, qs: Any, clearance: float, checked: tuple[int, int],
               want_pose: bool) -> tuple[str, CollisionReport | None, Pose | None, int]:
        """On the world's thread: states ``qs`` of a motion one after the other (``"gone"`` when the robot
        was removed, ``"collision"`` with the report at the first that touches, else ``"ok"`` with the
        last one's pose when ``want_pose``) and how many were reached."""
        world = self._world
        if robot not in world.robot_ids():
            return "gone", None, None, 0
        recheck = world.others_stamp(robot) != checked
        for k, q in enumerate(qs):
            if recheck:
                report = world.check_step(robot, reached, q, clearance)
                if not report.collision_free:
                    return "collision", report, None, k
            world.set_joint_positions(robot, q)
            reached = q
        return "ok", None, world.fk(robot) if want_pose else None, len(qs)

    def _final_pose(self, robot: str) -> Pose | None:
        return self._world.fk(robot) if robot in self._world.robot_ids() else None

    def _grip(self, robot: str, act: str, reached: Any,
              checked: tuple[int, int]) -> tuple[Any, tuple[int, int]]:
        """On the world's thread: a program's grip (``gripper.close``) or release (``gripper.open``); the
        state reached with the fingers where the gripper put them, and the stamp the states from here on
        were checked against: the world as the gripper leaves it (the program was planned through it),
        unless something else changed meanwhile (then every state is checked again)."""
        unchanged = self._world.others_stamp(robot) == checked
        if act == "grip":
            self._world.grippers.close(robot)
        else:
            self._world.grippers.open(robot)
        stamp = self._world.others_stamp(robot) if unchanged else checked
        return self._world.scene.entry(robot).bound.pin(reached), stamp

    async def _run(self, motion: _Motion, plan: TimedPath, realtime: float, checked: tuple[int, int],
                   clearance: float, starts: Sequence[int] = (), grips: Mapping[int, str] | None = None,
                   ) -> dict[str, Any]:
        loop = asyncio.get_running_loop()
        dt = plan.dt
        robot = motion.robot
        t0 = loop.time()
        reached = plan.first
        chunk, base = np.empty((0, len(reached))), 1  # the states from ``base`` on, computed as reached
        reached_time, reached_index = 0.0, 0
        status = "reached"
        contacts: list[dict[str, Any]] = []
        planned = (len(plan) - 1) * dt
        # the program step state i belongs to: the last step starting before it (None for a move)
        step_of = (lambda i: max(0, bisect.bisect_left(starts, i) - 1)) if starts else (lambda i: None)
        acts = sorted(grips or ())
        i = 1
        while i < len(plan):
            await motion.pause(t0 + i * dt / realtime - loop.time() if realtime > 0 else 0.0)
            if motion.stop_requested:
                status = "stopped"
                break
            n = self._due(loop.time() - t0, realtime, dt, i, len(plan), acts)
            if i + n > base + len(chunk):
                base, chunk = i, plan.rows(i, i + max(RUN_CHUNK, n))
            qs = chunk[i - base:i - base + n]
            if grips and i in grips:  # the gripper acts first: the states from here on have its fingers
                act = functools.partial(self._grip, robot, grips[i], reached, checked)
                reached, checked = await self._on_world(act, robot=robot, writes=True)
            last_time = (i + n - 1) * dt
            crosses = (math.floor(last_time / STATE_PERIOD + 1e-9)
                       > math.floor((i - 1) * dt / STATE_PERIOD + 1e-9))
            step = functools.partial(self._steps, robot, reached, qs, clearance, checked, crosses)
            outcome, report, pose, done = await self._on_world(step, robot=robot, writes=True)
            if done:
                reached, reached_index = qs[done - 1], i + done - 1
                reached_time = reached_index * dt
            if outcome == "gone":
                status = "stopped"
                break
            if outcome == "collision":
                assert report is not None
                status = "collision"
                contacts = [c.to_json() for c in report.contacts]
                self._broadcast("robot.collision", {
                    "robot": robot, "contacts": contacts, "positions": _floats(reached),
                    "time": reached_time})
                break
            if pose is not None:
                state = self._state(robot, reached_time, reached, pose, True, planned, step_of(reached_index))
                self._broadcast("robot.state", state)
            i += n
        wall = loop.time() - t0
        final = await self._on_world(functools.partial(self._final_pose, robot), robot=robot)
        if final is not None:
            self._broadcast("robot.state", self._state(robot, reached_time, reached, final, False, planned,
                                                       step_of(max(1, reached_index))))
        return {"status": status, "positions": _floats(reached), "duration": reached_time,
                "wallTime": wall, "contacts": contacts, "step": step_of(max(1, reached_index)) or 0}


    @staticmethod
    def _due(elapsed: float, realtime: float, dt: float, i: int, end: int, acts: Sequence[int]) -> int:
        """How many states from ``i`` on a run takes in one step of the world: those due by now at
        ``realtime`` (a run that fell behind its simulated clock catches up, every state still checked),
        at most ``CATCH_UP`` and never past a state where the gripper acts; one at real time 0."""
        n = 1
        if realtime > 0:
            due = math.floor(elapsed * realtime / dt + 1e-9)
            n = max(1, min(due - i + 1, CATCH_UP))
        later = bisect.bisect_right(acts, i)
        if later < len(acts):
            n = min(n, acts[later] - i)
        return max(1, min(n, end - i))


def _floats(values: Any) -> list[float]:
    return [float(v) for v in values]
