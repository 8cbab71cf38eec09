"""WebSocket adapter: feeds text frames to the sans-I/O dispatcher and sends replies/notifications.

One `World` per server process, shared by all connections. Every request runs as its own task so that a
long `robot.move` does not block `robot.stop` or `ping` on the same connection. The loop never calls
PyBullet: all world work runs on the world's one thread (`sim/world_thread.py`), which the loop awaits;
what needs no world (reading and decomposing meshes, `workspace.generate`'s waiting on its worker
processes, writing exports) runs in threads of its own (`off_world`). The loop takes no lock, so a ping,
a stop (answered from the loop's record of robots and motions) or another robot's motion step never
waits for a plan, an IK search, a decomposition or a mesh load.

`robot.state` / `robot.collision` go to every connected client, `workspace.progress` and
`robot.loadProgress` to the caller.
Each client has a bounded outbox (`Peer`): replies are never dropped, a robot's `robot.state` replaces
its older one not yet sent, a client with too much unsent is closed (1008, with the reason), and no
more of its frames are read while its unsent backlog is high or it has `MAX_IN_FLIGHT` requests
unanswered. Frames above the message limit are answered with E_TOO_LARGE; frames above the hard cap
(4x the limit) make websockets close that connection (code 1009) - the server carries on.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import logging
import os
import signal
import sys
import threading
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from http import HTTPStatus
from typing import Any, TypeVar

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from robwot_sim.motion_runner import MotionRunner
from robwot_sim.rpc.dispatch import Dispatcher
from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES, notification_message
from robwot_sim.rpc.table import build_dispatcher
from robwot_sim.sim.types import RobotModel
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind, WorldThread

log = logging.getLogger("robwot_sim.server")

T = TypeVar("T")

#: unsent frames (coalesced states count once per robot) or bytes past which a client is closed
OUTBOX_FRAMES = 10_000
OUTBOX_BYTES = 64 * 1024 * 1024
#: no more frames are read from a client while its unsent bytes exceed this
READ_PAUSE_BYTES = 1024 * 1024
#: requests of one client being served at once; its further frames wait unread
MAX_IN_FLIGHT = 256
#: seconds the shutdown waits for off-world threads (they cannot reach the world once it is drained)
OFF_WORLD_GRACE = 5.0
#: niceness of background off-world threads (mesh reading and decomposition)
BACKGROUND_NICE = 10
#: s: how long a thread holding the GIL runs before handing it to a waiting one (Python's default: 5 ms)
GIL_SWITCH_INTERVAL = 0.001
#: policy violation: the close code of a client that stays behind
CLOSE_TOO_SLOW = 1008


@dataclass
class _Slot:
    message: str | None  # None once superseded by a newer state of the same robot
    robot: str | None = None  # set for a robot.state notification


class Peer:
    """One client connection with a bounded, ordered outbox drained by a writer task (module docstring).
    The writer awaits each send, so websockets' own write buffer limit holds the rest here."""

    def __init__(self, conn: ServerConnection) -> None:
        self.conn = conn
        self._queue: deque[_Slot] = deque()
        self._states: dict[str, _Slot] = {}  # the queued robot.state of each robot
        self._frames = 0  # live slots in the queue
        self._dead = 0  # superseded slots still in the queue
        self._bytes = 0
        self._wake = asyncio.Event()
        self._room = asyncio.Event()
        self._room.set()
        self._in_flight = asyncio.Semaphore(MAX_IN_FLIGHT)
        self.closed = False
        self._writer = asyncio.create_task(self._drain())

    def push(self, message: str, *, state_of: str | None = None) -> None:
        """Queue a frame; with ``state_of`` (a robot's ``robot.state``) it replaces that robot's unsent
        one. A client past the bounds is closed instead."""
        if self.closed:
            return
        if state_of is not None and (old := self._states.get(state_of)) is not None and old.message:
            self._bytes -= len(old.message)
            old.message = None
            self._frames -= 1
            self._dead += 1
        slot = _Slot(message, state_of)
        self._queue.append(slot)
        if state_of is not None:
            self._states[state_of] = slot
        self._frames += 1
        self._bytes += len(message)
        if self._frames > OUTBOX_FRAMES or self._bytes > OUTBOX_BYTES:
            self._give_up(f"client too slow: {self._frames} frames ({self._bytes} bytes) unsent")
            return
        if self._dead > self._frames + 64:  # superseded slots would pile up while nothing is sent
            self._queue = deque(s for s in self._queue if s.message is not None)
            self._dead = 0
        if self._bytes > READ_PAUSE_BYTES:
            self._room.clear()
        self._wake.set()

    async def accept(self) -> None:
        """Wait until this client may have one more request served (backlog low, in-flight bound)."""
        await self._room.wait()
        await self._in_flight.acquire()

    def answered(self) -> None:
        self._in_flight.release()

    def _give_up(self, reason: str) -> None:
        log.warning("closing client %s: %s", self.conn.remote_address, reason)
        self.closed = True
        self._queue.clear()
        self._states.clear()
        self._frames = self._dead = self._bytes = 0
        self._room.set()
        self._writer.cancel()
        task = asyncio.create_task(self.conn.close(CLOSE_TOO_SLOW, reason[:120]))
        task.add_done_callback(lambda t: t.cancelled() or t.exception())

    async def _drain(self) -> None:
        try:
            while True:
                while not self._queue:
                    self._wake.clear()
                    await self._wake.wait()
                slot = self._queue.popleft()
                message = slot.message
                if message is None:
                    self._dead -= 1
                    continue
                if slot.robot is not None and self._states.get(slot.robot) is slot:
                    del self._states[slot.robot]
                self._frames -= 1
                self._bytes -= len(message)
                if self._bytes <= READ_PAUSE_BYTES:
                    self._room.set()
                await self.conn.send(message)
        except ConnectionClosed:
            self.closed = True
            self._room.set()  # the reading side must not wait for room that will never come

    async def close(self) -> None:
        self.closed = True
        self._room.set()
        self._writer.cancel()
        await asyncio.gather(self._writer, return_exceptions=True)


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

    async def handle_connection(self, conn: ServerConnection) -> None:
        peer = Peer(conn)
        self._peers.add(peer)

        def notify(method: str, params: dict[str, Any]) -> None:
            peer.push(notification_message(method, params))

        async def serve_one(frame: str | bytes) -> None:
            try:
                reply = await self.dispatcher.handle(frame, notify)
                if reply is not None:
                    peer.push(reply)
            finally:
                peer.answered()

        try:
            async for frame in conn:
                await peer.accept()  # backpressure: unread frames stay in websockets' bounded queue
                if peer.closed:
                    break
                task = asyncio.create_task(serve_one(frame))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        except ConnectionClosed:
            pass
        finally:
            self._peers.discard(peer)
            await peer.close()

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


def owner_check(token: str) -> Callable[[ServerConnection, Request], Response | None]:
    """The upgrade check: only a client presenting ``Authorization: Bearer <token>`` gets a connection.

    An upgrade carrying an ``Origin`` header comes from a web page (browsers always send one, scripts and
    the servient never do) and is refused before the token is even looked at. Exactly one
    ``Authorization`` header: several are refused (401) whatever they hold.
    """
    expected = f"Bearer {token}".encode()

    def check(conn: ServerConnection, request: Request) -> Response | None:
        # get_all: `get` raises on a repeated header, which websockets answers with a 500
        if request.headers.get_all("Origin"):
            return conn.respond(HTTPStatus.FORBIDDEN, "browser origins may not connect to the backend\n")
        given = request.headers.get_all("Authorization")
        if len(given) != 1 or not hmac.compare_digest(given[0].encode(), expected):
            return conn.respond(HTTPStatus.UNAUTHORIZED, "the backend's token is required "
                                "(Authorization: Bearer <ROBWOT_BACKEND_TOKEN>)\n")
        return None

    return check


def _watch_stdin(loop: asyncio.AbstractEventLoop, stop: asyncio.Event) -> None:
    """Set `stop` when stdin reaches end of file (the parent process died or closed the pipe)."""
    stdin_fd = sys.stdin.fileno()

    def wait_eof() -> None:
        try:  # raw fd reads: a daemon thread blocked in a buffered read aborts interpreter shutdown
            while os.read(stdin_fd, 4096):
                pass
        except (OSError, ValueError):
            pass
        if not loop.is_closed():
            loop.call_soon_threadsafe(stop.set)

    threading.Thread(target=wait_eof, name="robwot-stdin-watch", daemon=True).start()


async def run_server(host: str = "127.0.0.1", port: int = 0, *, token: str,
                     max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES,
                     on_ready: Callable[[int], None] | None = None,
                     stop: asyncio.Event | None = None, exit_on_stdin_eof: bool = False) -> None:
    """Serve until `stop` is set (or SIGTERM/SIGINT when `stop` is None); `on_ready(port)` once listening.

    Only clients presenting `token` (see `owner_check`) are served.

    With `exit_on_stdin_eof`, also stop when stdin closes: a launcher that keeps a pipe to our stdin thus
    takes the server down with it even when it is killed without a chance to clean up.
    """
    loop = asyncio.get_running_loop()
    # the world's thread holds the GIL while it computes: hand it over sooner than the default 5 ms, so
    # that the loop's turn (a ping, a stop, a step) comes within a millisecond or so
    sys.setswitchinterval(GIL_SWITCH_INTERVAL)
    if stop is None:
        stop = asyncio.Event()
        for sig in (signal.SIGTERM, signal.SIGINT):
            loop.add_signal_handler(sig, stop.set)
    if exit_on_stdin_eof:
        _watch_stdin(loop, stop)
    with World() as world:
        backend = Backend(world, max_message_bytes)
        hard_cap = max(4 * max_message_bytes, max_message_bytes + 1024 * 1024)
        async with serve(backend.handle_connection, host, port, max_size=hard_cap, ping_timeout=60,
                         process_request=owner_check(token)) as server:
            bound = next(iter(server.sockets)).getsockname()[1]
            if on_ready is not None:
                on_ready(int(bound))
            await stop.wait()
            await backend.shutdown()
    # leaving `with World()` closes it: after the shutdown drained its thread, nothing else uses it
