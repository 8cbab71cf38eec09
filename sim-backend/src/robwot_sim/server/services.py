"""The running server's services for the method handlers (`rpc.services.Services`): the world through
its one thread, threads off the world, the motion runner, the loaded robots' models and the clients'
outboxes a broadcast reaches.

The loop never calls PyBullet: all world work runs on the world's one thread (`sim/world_thread.py`),
which the loop awaits; what needs no world (reading and decomposing meshes, `workspace.generate`'s
waiting on its worker processes, writing exports) runs in threads of its own (`off_world`). The loop
takes no lock, so a ping, a stop (answered from the loop's record of robots and motions) or another
robot's motion step never waits for a plan, an IK search, a decomposition or a mesh load.
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import sys
import threading
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

from robwot_sim.model.robot_model import RobotModel
from robwot_sim.motion_runner import MotionRunner
from robwot_sim.rpc.dispatch import Dispatcher
from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES, notification_message
from robwot_sim.rpc.table import build_dispatcher
from robwot_sim.server.peer import Peer
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind, WorldThread

T = TypeVar("T")

#: seconds the shutdown waits for off-world threads (they cannot reach the world once it is drained)
OFF_WORLD_GRACE = 5.0
#: niceness of background off-world threads (mesh reading and decomposition)
BACKGROUND_NICE = 10


class Backend:
    """The running server's services for the method handlers (see `rpc.services.Services`)."""

    def __init__(self, world: World, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> None:
        self._world = world
        self._loop = asyncio.get_running_loop()
        self._peers: set[Peer] = set()
        self._tasks: set[asyncio.Task[None]] = set()
        self._off_world: set[asyncio.Future[Any]] = set()
        self._models: dict[str, RobotModel] = {rid: world.robot_model(rid) for rid in world.robot_ids()}
        self._world_thread = WorldThread()
        self._world_thread.submit(world.bind)  # from now on only the world's thread may use it
        self._motions = MotionRunner(world, self.broadcast, self.on_world)
        # the test suites set ROBWOT_CHECK_RESULTS=1: every result is checked against the contract
        self.dispatcher: Dispatcher = build_dispatcher(
            self, max_message_bytes, check_results=os.environ.get("ROBWOT_CHECK_RESULTS") == "1")

    @property
    def world(self) -> World:
        return self._world

    @property
    def robots(self) -> Mapping[str, RobotModel]:
        return self._models

    @property
    def motions(self) -> MotionRunner:
        return self._motions

    async def on_world(self, fn: Callable[[], T], kind: Kind = Kind.SHORT, *, robot: str | None = None,
                       writes: bool = False, cancel: threading.Event | None = None,
                       budget: float | None = None) -> T:
        job = self._world_thread.submit(fn, kind, robot=robot, writes=writes, cancel=cancel, budget=budget)
        try:
            return await asyncio.wrap_future(job.future)
        except asyncio.CancelledError:
            job.cancel.set()  # a running long job stops at its next checkpoint
            raise

    async def change_world(self, fn: Callable[[], T], kind: Kind = Kind.PLAIN) -> T:
        def run() -> T:
            try:
                return fn()
            finally:  # queued before the job's result: the record is fresh when the handler resumes
                models = {rid: self._world.robot_model(rid) for rid in self._world.robot_ids()}
                self._call_soon(self._set_models, models)

        return await self.on_world(run, kind)

    def _set_models(self, models: dict[str, RobotModel]) -> None:
        self._models = models

    def off_world(self, fn: Callable[[], T], *, background: bool = False) -> asyncio.Future[T]:
        future: asyncio.Future[T] = self._loop.create_future()

        def settle(ok: bool, value: Any) -> None:
            if future.done():
                return
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)

        def work() -> None:
            if background:
                _lower_priority()
            try:
                result = fn()
            except BaseException as exc:  # forwarded to the awaiting handler
                self._call_soon(settle, False, exc)
            else:
                self._call_soon(settle, True, result)

        # daemon threads: a decomposition or a generation must not hold the process at exit
        threading.Thread(target=work, name="robwot-off-world", daemon=True).start()
        self._off_world.add(future)
        future.add_done_callback(self._off_world.discard)
        return future

    def _call_soon(self, fn: Callable[..., None], *args: Any) -> None:
        if not self._loop.is_closed():
            self._loop.call_soon_threadsafe(fn, *args)

    def call_world(self, fn: Callable[[], T]) -> T:
        return self._world_thread.call(fn)

    def threadsafe(self, fn: Callable[[str, dict[str, Any]], None]) -> Callable[[str, dict[str, Any]], None]:
        def call(method: str, params: dict[str, Any]) -> None:
            self._call_soon(fn, method, params)

        return call

    def broadcast(self, method: str, params: dict[str, Any]) -> None:
        message = notification_message(method, params)
        state_of = str(params["robot"]) if method == "robot.state" else None
        for peer in list(self._peers):
            peer.push(message, state_of=state_of)

    def connect(self, peer: Peer) -> None:
        """From now on `broadcast` reaches ``peer``."""
        self._peers.add(peer)

    def disconnect(self, peer: Peer) -> None:
        self._peers.discard(peer)

    def track(self, task: asyncio.Task[None]) -> None:
        """A request being served: `shutdown` cancels it and waits for it."""
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    async def shutdown(self) -> None:
        """Stop the motions, cancel the requests and wait for them, drain the world's thread (queued jobs
        cancelled, a running search stopped at its next checkpoint, the thread ended), then give the
        off-world threads a moment: after this the world may be closed."""
        await self._motions.stop_and_wait()
        tasks = list(self._tasks)
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        await asyncio.to_thread(self._world_thread.shutdown)
        if self._off_world:
            await asyncio.wait(list(self._off_world), timeout=OFF_WORLD_GRACE)


def _lower_priority() -> None:
    """Give the calling thread (and the threads it starts: a decomposition's, one per core) a lower CPU
    priority, so that when they fill every core the loop and the world's threads still run at once."""
    if sys.platform.startswith("linux"):  # PRIO_PROCESS with a thread id: that thread alone
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), BACKGROUND_NICE)

