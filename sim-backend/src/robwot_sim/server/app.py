"""The backend's WebSocket server (composition root): the world, the services around it, one outbox per
client, the owner's token at the upgrade.

One `World` per server process, shared by all connections. Every request runs as its own task so that a
long `robot.move` does not block `robot.stop` or `ping` on the same connection (`services.py` says why the
loop never waits for the world). `robot.state` / `robot.collision` go to every connected client,
`workspace.progress` and `robot.loadProgress` to the caller; each client's frames pass through its
bounded outbox (`peer.py`). Frames above the message limit are answered with E_TOO_LARGE; frames above
the hard cap (4x the limit) make websockets close that connection (code 1009) - the server carries on.
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import threading
from collections.abc import Callable
from functools import partial
from typing import Any

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES, notification_message
from robwot_sim.server.auth import owner_check
from robwot_sim.server.peer import Peer
from robwot_sim.server.services import Backend
from robwot_sim.sim.world import World

#: s: how long a thread holding the GIL runs before handing it to a waiting one (Python's default: 5 ms)
GIL_SWITCH_INTERVAL = 0.001


async def serve_connection(backend: Backend, conn: ServerConnection) -> None:
    """Serve one client until it goes: each of its requests a task of its own, its frames unread while
    its outbox is behind."""
    peer = Peer(conn)
    backend.connect(peer)

    def notify(method: str, params: dict[str, Any]) -> None:
        peer.push(notification_message(method, params))

    async def serve_one(frame: str | bytes) -> None:
        try:
            reply = await backend.dispatcher.handle(frame, notify)
            if reply is not None:
                peer.push(reply)
        finally:
            peer.answered()

    try:
        async for frame in conn:
            await peer.accept()  # backpressure: unread frames stay in websockets' bounded queue
            if peer.closed:
                break
            backend.track(asyncio.create_task(serve_one(frame)))
    except ConnectionClosed:
        pass
    finally:
        backend.disconnect(peer)
        await peer.close()


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
        # no permessage-deflate: the backend serves its own machine, where compressing a frame costs more
        # time than sending its bytes (README, "Servient")
        async with serve(partial(serve_connection, backend), host, port, max_size=hard_cap, ping_timeout=60,
                         process_request=owner_check(token), compression=None) as server:
            bound = next(iter(server.sockets)).getsockname()[1]
            if on_ready is not None:
                on_ready(int(bound))
            await stop.wait()
            await backend.shutdown()
    # leaving `with World()` closes it: after the shutdown drained its thread, nothing else uses it
