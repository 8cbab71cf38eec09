"""Executes robot motions on the asyncio loop: one operation per move — plan, then run — streamed.

`robot.move` takes the robot (busy from here: `E_BUSY` for a second move, `stop` ends it), plans the
target (`sim/planner.py`: limits, IK solutions, a collision-free path; `Rejected` when none), asks the
world for the interpolated path (`World.plan_motion`, velocity limits x speed, fixed dt), then for every
step: waits until its wall-clock due time (`t0 + t_sim / realtime`; with realtime 0 it only yields to
the loop) and teleports the robot there. The plan checked this very path; once anything else in the
world changes during the motion (an obstacle added or moved, another robot moving: `World.others_stamp`)
every further step is checked again (`World.check_step`: subdivided so no point travels more than twice
the clearance unchecked, other bodies kept the clearance away).
A colliding step ends the motion at the last collision-free state (`status: "collision"`, a
`robot.collision` notification). `robot.state` notifications go out at every step whose simulated time
crosses a 1/60 s boundary, plus the final state (`moving: false`). One motion per robot: a second
`move` raises `Busy`; `stop` ends the current motion at its last reached state (`status: "stopped"`)
and returns once it has ended, so a new `move` may follow at once.

PyBullet calls happen on the loop thread between awaits, except the plan: it runs in a worker thread
holding the world (`plan_off_loop`), so the loop stays responsive; the world's lock keeps the two apart.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Awaitable, Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robwot_sim.errors import Busy, Rejected, UnknownRobot
from robwot_sim.sim.planner import Plan
from robwot_sim.sim.world import World

Broadcast = Callable[[str, dict[str, Any]], None]
RunBlocking = Callable[[Callable[[], Plan]], Awaitable[Plan]]

STATE_PERIOD = 1.0 / 60.0


@dataclass
class _Motion:
    robot: str
    stop: asyncio.Event = field(default_factory=asyncio.Event)
    done: asyncio.Event = field(default_factory=asyncio.Event)

    @property
    def stop_requested(self) -> bool:
        return self.stop.is_set()

    async def pause(self, delay: float) -> None:
        """Sleep `delay` seconds (always yielding to the loop), waking early on a stop request."""
        if delay <= 0:
            await asyncio.sleep(0)
            return
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self.stop.wait(), delay)


class MotionRunner:
    """Runs at most one motion per robot; motions of different robots run concurrently."""

    def __init__(self, world: World, broadcast: Broadcast, run_blocking: RunBlocking) -> None:
        self._world = world
        self._broadcast = broadcast
        self._run_blocking = run_blocking
        self._active: dict[str, _Motion] = {}

    def is_moving(self, robot: str) -> bool:
        return robot in self._active

    async def stop(self, robot: str) -> bool:
        """Stop the robot's motion and wait until it has ended; True when one was running."""
        motion = self._active.get(robot)
        if motion is None:
            return False
        motion.stop.set()
        await motion.done.wait()
        return True

    async def stop_and_wait(self, robots: Sequence[str] | None = None) -> None:
        """Stop the given robots' motions (all when None) and wait until they have ended."""
        motions = [m for r, m in self._active.items() if robots is None or r in robots]
        for motion in motions:
            motion.stop.set()
        for motion in motions:
            await motion.done.wait()

    async def move(self, robot: str, planner: Callable[[], Plan], *, speed: float = 1.0,
                   realtime: float = 1.0, dt: float = 1.0 / 240.0) -> dict[str, Any]:
        """Plan with `planner` and move `robot` to the plan's joint target; returns the MoveResult dict
        (with the plan). `Rejected` when the plan is not valid: nothing moved."""
        if robot in self._active:
            raise Busy(robot)
        motion = _Motion(robot)
        self._active[robot] = motion
        try:
            # the plan checks exactly this path in this world: steps are checked again once anything else
            # changes from here on (stamped before planning: a change during or after it counts)
            stamp = self._world.others_stamp(robot)
            plan = await plan_off_loop(self._world, planner, self._run_blocking)
            if not plan.valid or plan.target is None:
                raise Rejected(plan.reasons, plan.checks)
            path = self._world.plan_motion(robot, plan.target, speed=speed, dt=dt, via=plan.via)
            result = await self._run(motion, np.asarray(path, dtype=np.float64), realtime, dt, stamp)
            return {**result, "plan": plan.to_json()}
        finally:
            del self._active[robot]
            motion.done.set()

    def _state(self, robot: str, time: float, q: Any, moving: bool, planned: float) -> dict[str, Any]:
        """A ``robot.state`` notification: joints and the end-effector pose at the robot's current state
        (``q``, just applied), so no client needs an FK round trip per notification; ``planned`` is the
        simulated duration of the whole path (``time / planned`` = the motion's progress)."""
        return {"robot": robot, "time": time, "planned": planned, "positions": _floats(q), "moving": moving,
                **_pose_json(self._world, robot)}

    async def _run(self, motion: _Motion, plan: np.ndarray[Any, Any], realtime: float,
                   dt: float, checked: tuple[int, int]) -> dict[str, Any]:
        loop = asyncio.get_running_loop()
        robot = motion.robot
        t0 = loop.time()
        reached = plan[0]
        reached_time = 0.0
        status = "reached"
        contacts: list[dict[str, Any]] = []
        clearance = self._world.motion_clearance(robot)
        planned = (len(plan) - 1) * dt
        for i in range(1, len(plan)):
            sim_time = i * dt
            await motion.pause(t0 + sim_time / realtime - loop.time() if realtime > 0 else 0.0)
            if motion.stop_requested:
                status = "stopped"
                break
            if robot not in self._world.robot_ids():
                status = "stopped"
                break
            q = plan[i]
            if self._world.others_stamp(robot) != checked:
                report = self._world.check_step(robot, reached, q, clearance)
                if not report.collision_free:
                    status = "collision"
                    contacts = [c.to_json() for c in report.contacts]
                    self._broadcast("robot.collision", {
                        "robot": robot, "contacts": contacts, "positions": _floats(reached),
                        "time": reached_time})
                    break
            self._world.set_joint_positions(robot, q)
            reached, reached_time = q, sim_time
            if math.floor(sim_time / STATE_PERIOD + 1e-9) > math.floor((sim_time - dt) / STATE_PERIOD + 1e-9):
                self._broadcast("robot.state", self._state(robot, sim_time, q, True, planned))
        wall = loop.time() - t0
        if robot in self._world.robot_ids():
            self._broadcast("robot.state", self._state(robot, reached_time, reached, False, planned))
        return {"status": status, "positions": _floats(reached), "duration": reached_time,
                "wallTime": wall, "contacts": contacts}


async def plan_off_loop(world: World, planner: Callable[[], Plan], run_blocking: RunBlocking) -> Plan:
    """Run `planner` in a worker thread holding the world (`World.exclusive`): a plan (IK solutions, a
    detour within its 2 s budget) may take seconds, and meanwhile the loop keeps answering what needs no
    world — the heartbeat `ping`, a `stop` (which then ends the motion before its first step)."""
    def locked() -> Plan:
        with world.exclusive():
            return planner()

    return await run_blocking(locked)


def _pose_json(world: World, robot: str) -> dict[str, Any]:
    pose = world.fk(robot)
    return {"position": _floats(pose.position), "orientation": _floats(pose.quat_xyzw)}


def require_robot(world: World, robot: str) -> None:
    """Raise UnknownRobot unless `robot` is loaded."""
    ids = world.robot_ids()
    if robot not in ids:
        raise UnknownRobot(robot, ids)


def _floats(values: Any) -> list[float]:
    return [float(v) for v in values]
