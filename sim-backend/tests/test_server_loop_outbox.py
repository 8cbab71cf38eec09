"""A client's outbox (`server.peer.Peer`): replies never dropped, a robot's states coalesced to the latest, a
client that stays behind closed with a reason, its frames left unread while its backlog is high."""

from __future__ import annotations

import asyncio
import json
from typing import Any, cast

from websockets.asyncio.server import ServerConnection

from robwot_sim.server.peer import CLOSE_TOO_SLOW, OUTBOX_FRAMES, READ_PAUSE_BYTES, Peer


class StalledConnection:
    """Stands in for a websockets connection whose client reads nothing until `gate` is set."""

    remote_address = ("192.0.2.1", 1)

    def __init__(self) -> None:
        self.gate = asyncio.Event()
        self.sent: list[str] = []
        self.closed_with: tuple[int, str] | None = None

    async def send(self, message: str) -> None:
        await self.gate.wait()
        self.sent.append(message)

    async def close(self, code: int = 1000, reason: str = "") -> None:
        self.closed_with = (code, reason)


def _peer(conn: StalledConnection) -> Peer:
    return Peer(cast(ServerConnection, conn))


def _state(robot: str, time: float) -> str:
    return json.dumps({"jsonrpc": "2.0", "method": "robot.state", "params": {"robot": robot, "time": time}})


async def _settle(conn: StalledConnection, count: int) -> None:
    for _ in range(10_000):
        if len(conn.sent) >= count:
            return
        await asyncio.sleep(0)


def test_states_coalesce_and_every_reply_is_kept_in_order() -> None:
    """50,000 `robot.state` of three robots interleaved with replies, to a client not reading: every
    reply is sent, in order, and of the states only each robot's latest (the old outbox dropped every
    frame, replies included, past 10,000 queued)."""
    async def run() -> list[Any]:
        conn = StalledConnection()
        peer = _peer(conn)
        await asyncio.sleep(0)
        for i in range(50_000):
            peer.push(_state("abc"[i % 3], i), state_of="abc"[i % 3])
            if i % 5_000 == 0:
                peer.push(json.dumps({"jsonrpc": "2.0", "id": i, "result": {}}))
        assert not peer.closed
        conn.gate.set()
        await _settle(conn, 10 + 3 + 1)  # the first frame was taken before the gate opened
        await peer.close()
        return [json.loads(m) for m in conn.sent]

    sent = asyncio.run(run())
    replies = [d["id"] for d in sent if "id" in d]
    assert replies == list(range(0, 50_000, 5_000))
    states = [d["params"] for d in sent if d.get("method") == "robot.state"]
    latest = {s["robot"]: s["time"] for s in states}
    assert latest == {"a": 49_998, "b": 49_999, "c": 49_997}
    assert len(states) <= 4  # one each, plus the one in flight when the client stalled


def test_a_client_that_stays_behind_is_closed_with_a_reason() -> None:
    """Past `OUTBOX_FRAMES` unsent replies the client is closed (1008, the reason given) and its outbox
    freed, instead of frames being dropped silently while it stays connected."""
    async def run() -> tuple[StalledConnection, Peer]:
        conn = StalledConnection()
        peer = _peer(conn)
        for i in range(OUTBOX_FRAMES + 2):
            peer.push(json.dumps({"jsonrpc": "2.0", "id": i, "result": {}}))
        await asyncio.sleep(0)
        await peer.close()
        return conn, peer

    conn, peer = asyncio.run(run())
    assert peer.closed
    assert conn.closed_with is not None and conn.closed_with[0] == CLOSE_TOO_SLOW
    assert "too slow" in conn.closed_with[1]


def test_no_more_frames_are_read_while_the_backlog_is_high() -> None:
    """Once a client's unsent bytes pass `READ_PAUSE_BYTES`, `accept` (the reader's gate) waits until
    they have been sent: a client that floods requests without reading replies stops being read."""
    async def run() -> tuple[bool, bool]:
        conn = StalledConnection()
        peer = _peer(conn)
        await peer.accept()
        peer.answered()
        chunk = "x" * 65_536
        for _ in range(READ_PAUSE_BYTES // len(chunk) + 2):
            peer.push(chunk)
        try:
            await asyncio.wait_for(peer.accept(), 0.2)
            paused = False
        except TimeoutError:
            paused = True
        conn.gate.set()
        await asyncio.wait_for(peer.accept(), 5)
        resumed = True
        await peer.close()
        return paused, resumed

    assert asyncio.run(run()) == (True, True)
