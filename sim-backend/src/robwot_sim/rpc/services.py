"""What the method handlers need from the running server, as protocols (no asyncio import here)."""

from __future__ import annotations

from collections.abc import Awaitable, Callable, Sequence
from typing import Any, Protocol, TypeVar

from robwot_sim.sim.planner import Plan
from robwot_sim.sim.world import World

T = TypeVar("T")


class Motions(Protocol):
    """The motion runner (see `robwot_sim.motion_runner.MotionRunner`)."""

    def is_moving(self, robot: str) -> bool: ...

    async def stop(self, robot: str) -> bool: ...

    async def stop_and_wait(self, robots: Sequence[str] | None = None) -> None: ...

    async def move(self, robot: str, planner: Callable[[], Plan], *, speed: float = 1.0,
                   realtime: float = 1.0, dt: float = 1.0 / 240.0) -> dict[str, Any]: ...


class Services(Protocol):
    """The world, the motion runner and the server's I/O hooks."""

    @property
    def world(self) -> World: ...

    @property
    def motions(self) -> Motions: ...

    def run_blocking(self, fn: Callable[[], T]) -> Awaitable[T]:
        """Run `fn` in a worker thread; the loop keeps serving requests meanwhile."""
        ...

    def threadsafe(self, fn: Callable[[str, dict[str, Any]], None]) -> Callable[[str, dict[str, Any]], None]:
        """Wrap a notify function so that a worker thread may call it."""
        ...

    def broadcast(self, method: str, params: dict[str, Any]) -> None:
        """Send a notification to every connected client."""
        ...
