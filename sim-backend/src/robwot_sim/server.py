"""WebSocket adapter: feeds text frames to the sans-I/O dispatcher and sends replies/notifications.

One `World` per server process, shared by all connections. Every request runs as its own task so that a
long `robot.move` does not block `robot.stop` or `ping` on the same connection. PyBullet is only called
from the loop thread (handlers are synchronous between awaits); blocking work (`workspace.generate`) runs
in a daemon thread. `robot.state` / `robot.collision` go to every connected client, `workspace.progress`
to the caller. Frames above the message limit are answered with E_TOO_LARGE; frames above the hard cap
(4x the limit) make websockets close that connection (code 1009) - the server carries on.
"""

from __future__ import annotations

import asyncio
import hmac
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable
from http import HTTPStatus
from typing import Any, TypeVar

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from robwot_sim.motion_runner import MotionRunner
from robwot_sim.rpc.dispatch import Dispatcher
from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES, notification_message
from robwot_sim.rpc.table import build_dispatcher
from robwot_sim.sim.world import World

log = logging.getLogger("robwot_sim.server")

T = TypeVar("T")

OUTBOX_LIMIT = 10_000


class Peer:
    """One client connection with an ordered outbox drained by a writer task."""

    def __init__(self, conn: ServerConnection) -> None:
        self.conn = conn
        self._outbox: asyncio.Queue[str] = asyncio.Queue()
        self._writer = asyncio.create_task(self._drain())

    def push(self, message: str) -> None:
        if self._outbox.qsize() >= OUTBOX_LIMIT:
            log.warning("client %s is not reading; dropping a message", self.conn.remote_address)
            return
        self._outbox.put_nowait(message)

    async def _drain(self) -> None:
        try:
            while True:
                message = await self._outbox.get()
                await self.conn.send(message)
        except ConnectionClosed:
            return

    def close(self) -> None:
        self._writer.cancel()


class Backend:
    """The running server's services for the method handlers (see `rpc.services.Services`)."""

    def __init__(self, world: World, max_message_bytes: int = DEFAULT_MAX_MESSAGE_BYTES) -> None:
        self._world = world
        self._loop = asyncio.get_running_loop()
        self._peers: set[Peer] = set()
        self._tasks: set[asyncio.Task[None]] = set()
        self._motions = MotionRunner(world, self.broadcast, self.run_blocking)
        # the test suites set ROBWOT_CHECK_RESULTS=1: every result is checked against the contract
        self.dispatcher: Dispatcher = build_dispatcher(
            self, max_message_bytes, check_results=os.environ.get("ROBWOT_CHECK_RESULTS") == "1")

    @property
    def world(self) -> World:
        return self._world

    @property
    def motions(self) -> MotionRunner:
        return self._motions

    def run_blocking(self, fn: Callable[[], T]) -> asyncio.Future[T]:
        future: asyncio.Future[T] = self._loop.create_future()

        def settle(ok: bool, value: Any) -> None:
            if future.done():
                return
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)

        def work() -> None:
            try:
                result = fn()
            except BaseException as exc:  # forwarded to the awaiting handler
                self._loop.call_soon_threadsafe(settle, False, exc)
            else:
                self._loop.call_soon_threadsafe(settle, True, result)

        threading.Thread(target=work, name="robwot-blocking", daemon=True).start()
        return future

    def threadsafe(self, fn: Callable[[str, dict[str, Any]], None]) -> Callable[[str, dict[str, Any]], None]:
        def call(method: str, params: dict[str, Any]) -> None:
            if not self._loop.is_closed():
                self._loop.call_soon_threadsafe(fn, method, params)

        return call

    def broadcast(self, method: str, params: dict[str, Any]) -> None:
        message = notification_message(method, params)
        for peer in list(self._peers):
            peer.push(message)

    async def handle_connection(self, conn: ServerConnection) -> None:
        peer = Peer(conn)
        self._peers.add(peer)

        def notify(method: str, params: dict[str, Any]) -> None:
            peer.push(notification_message(method, params))

        async def serve_one(frame: str | bytes) -> None:
            reply = await self.dispatcher.handle(frame, notify)
            if reply is not None:
                peer.push(reply)

        try:
            async for frame in conn:
                task = asyncio.create_task(serve_one(frame))
                self._tasks.add(task)
                task.add_done_callback(self._tasks.discard)
        except ConnectionClosed:
            pass
        finally:
            self._peers.discard(peer)
            peer.close()

    async def shutdown(self) -> None:
        await self._motions.stop_and_wait()
        for task in list(self._tasks):
            task.cancel()


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
