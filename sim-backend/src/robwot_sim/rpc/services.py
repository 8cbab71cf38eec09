"""What the method handlers need from the running server, as protocols (no asyncio import here).

The world is used only through `on_world` / `change_world` (its one thread, `sim/world_thread.py`);
what needs no world (reading files, decomposing meshes, writing exports) goes to `off_world`. A handler
never calls a `World` method itself: the loop would then wait on PyBullet.
"""

from __future__ import annotations

import threading
from collections.abc import Awaitable, Callable, Mapping, Sequence
from typing import Any, Protocol, TypeVar

from robwot_sim.limits import DEFAULT_DT
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.sim.planner import Plan
from robwot_sim.sim.program import ProgramStep
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind

T = TypeVar("T")


class Motions(Protocol):
    """The motion runner (see `robwot_sim.motion_runner.MotionRunner`)."""

    def is_moving(self, robot: str) -> bool: ...

    async def stop(self, robot: str) -> bool: ...

    async def stop_and_wait(self, robots: Sequence[str] | None = None) -> None: ...

    async def move(self, robot: str, planner: Callable[[], Plan], *,
                   realtime: float = 1.0) -> dict[str, Any]: ...

    async def run_program(self, robot: str, steps: Sequence[ProgramStep], *, realtime: float = 1.0,
                          dt: float = DEFAULT_DT) -> dict[str, Any]: ...


class Services(Protocol):
    """The world (through its thread), the motion runner and the server's I/O hooks."""

    @property
    def world(self) -> World:
        """The world, for the functions handed to `on_world` / `change_world` (they run on its thread)."""
        ...

    @property
    def robots(self) -> Mapping[str, RobotModel]:
        """The loaded robots' models, kept on the loop (refreshed by `change_world`): what `robot.stop`,
        `robot.model` and the params' checks read without waiting for the world."""
        ...

    @property
    def motions(self) -> Motions: ...

    def on_world(self, fn: Callable[[], T], kind: Kind = Kind.SHORT, *, robot: str | None = None,
                 writes: bool = False, cancel: threading.Event | None = None,
                 budget: float | None = None) -> Awaitable[T]:
        """Run `fn` on the world's thread (`world_thread.Kind`); `robot` / `writes`: what a short job
        touches. A long job stops at its next checkpoint once `cancel` is set or the await is cancelled,
        or (`PlanBudget`) once it has run `budget` seconds."""
        ...

    def change_world(self, fn: Callable[[], T], kind: Kind = Kind.PLAIN) -> Awaitable[T]:
        """Run `fn` (robots loaded or removed) on the world's thread, then refresh `robots`. `Kind.LONG`
        for a load: its collision filter reaches checkpoints (the new body is in no table until added)."""
        ...

    def off_world(self, fn: Callable[[], T], *, background: bool = False) -> Awaitable[T]:
        """Run `fn`, which needs no world, in a thread of its own; the loop keeps serving meanwhile.
        `background`: at a lower CPU priority (with the threads it starts), for work that may fill every
        core (a decomposition), so that the loop and the world's thread still get one at once."""
        ...

    def call_world(self, fn: Callable[[], T]) -> T:
        """From an `off_world` thread: run `fn` on the world's thread (a plain job) and wait for it."""
        ...

    def threadsafe(self, fn: Callable[[str, dict[str, Any]], None]) -> Callable[[str, dict[str, Any]], None]:
        """Wrap a notify function so that another thread may call it."""
        ...

    def broadcast(self, method: str, params: dict[str, Any]) -> None:
        """Send a notification to every connected client."""
        ...
