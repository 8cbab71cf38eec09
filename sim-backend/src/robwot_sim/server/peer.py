"""A client's bounded outbox (python-websockets' connection side of the split).

Replies are never dropped, a robot's `robot.state` replaces its older one not yet sent, a client with too
much unsent is closed (1008, with the reason), and no more of its frames are read while its unsent
backlog is high or it has `MAX_IN_FLIGHT` requests unanswered.
"""

from __future__ import annotations

import asyncio
import logging
from collections import deque
from dataclasses import dataclass

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed

log = logging.getLogger("robwot_sim.server")

#: unsent frames (coalesced states count once per robot) or bytes past which a client is closed
OUTBOX_FRAMES = 10_000
OUTBOX_BYTES = 64 * 1024 * 1024
#: no more frames are read from a client while its unsent bytes exceed this
READ_PAUSE_BYTES = 1024 * 1024
#: requests of one client being served at once; its further frames wait unread
MAX_IN_FLIGHT = 256
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
