"""Request bodies are capped on the backend (issue 34, "request bodies capped on every server we run"): a
message above the RPC limit is answered E_TOO_LARGE on a connection that stays usable; one above the hard
cap closes that connection with 1009 (message too big) and a reason, however it arrives (one frame
announcing a gigabyte, fragments adding up past the cap), and never grows the backend's memory by what was
announced; other clients are served throughout. No frame is ever inflated: permessage-deflate is never
negotiated."""

from __future__ import annotations

import base64
import json
import os
import socket
import struct
import time

import pytest
from rpc_backend import LEGACY, BackendProcess, RpcClient
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from robwot_sim.rpc.protocol import DEFAULT_MAX_MESSAGE_BYTES

LIMIT = DEFAULT_MAX_MESSAGE_BYTES
#: MB the backend's resident memory may grow while refusing (the frames announce or inflate to far more)
MEMORY_BOUND = 64
#: the WebSocket close code of a message above the size limit (RFC 6455)
MESSAGE_TOO_BIG = 1009


def _rss(backend: BackendProcess) -> int:
    with open(f"/proc/{backend.proc.pid}/status") as f:
        return int(next(line for line in f if line.startswith("VmRSS:")).split()[1]) // 1024


def _raw(backend: BackendProcess) -> socket.socket:
    """A TCP connection upgraded to WebSocket by hand (so frames can lie about their length)."""
    sock = socket.create_connection(("127.0.0.1", backend.port), timeout=10)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{backend.port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                  f"Authorization: Bearer {backend.token}\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(4096)
    assert head.startswith(b"HTTP/1.1 101"), head[:100]
    return sock


def _close_code(sock: socket.socket, timeout: float = 10.0) -> tuple[int, str]:
    """The code and reason of the close frame the server sends."""
    sock.settimeout(timeout)
    data = b""
    while len(data) < 2 or len(data) < 2 + (data[1] & 0x7F):
        chunk = sock.recv(4096)
        assert chunk, "closed without a close frame"
        data += chunk
    assert data[0] & 0x0F == 0x8, f"not a close frame: {data[:8]!r}"
    payload = data[2:2 + (data[1] & 0x7F)]
    return struct.unpack("!H", payload[:2])[0], payload[2:].decode()


def test_a_frame_announcing_a_gigabyte_is_closed_at_its_header(backend: BackendProcess,
                                                               client: RpcClient) -> None:
    """Its header says 2^30 bytes: 1009 with a reason at once, before any of it is buffered."""
    before = _rss(backend)
    sock = _raw(backend)
    try:
        mask = os.urandom(4)
        sock.sendall(bytes([0x81, 0x80 | 127]) + struct.pack("!Q", 2**30) + mask + b"\0" * 65536)
        t = time.monotonic()
        code, reason = _close_code(sock)
        assert code == MESSAGE_TOO_BIG and reason and time.monotonic() - t < 5
    finally:
        sock.close()
    assert _rss(backend) - before < MEMORY_BOUND
    assert client.call("ping")["version"]


def test_a_message_growing_past_the_hard_cap_closes_only_its_connection(backend: BackendProcess,
                                                                       client: RpcClient) -> None:
    """1 MiB fragments adding up to 64 MiB: the connection is closed with 1009 once the message passes the
    cap, the backend's memory stays within MEMORY_BOUND MB of where it was, and the other client is
    served."""
    before = _rss(backend)
    ws = connect(backend.url, additional_headers={"Authorization": f"Bearer {backend.token}"},
                 max_size=None, compression=None, **LEGACY)
    try:
        with pytest.raises(ConnectionClosed):
            ws.send("a" * (1 << 20) for _ in range(64))
            ws.recv(timeout=10)
    finally:
        ws.close()
    assert ws.close_code == MESSAGE_TOO_BIG and ws.close_reason
    assert _rss(backend) - before < MEMORY_BOUND
    assert client.call("ping")["version"]


def test_permessage_deflate_is_never_negotiated(backend: BackendProcess) -> None:
    """A client offering permessage-deflate (python-websockets does by default) gets plain frames: no frame
    is inflated (a small one could inflate past the cap), and the backend serves its own machine, where
    compressing costs more time than the bytes it saves."""
    ws = connect(backend.url, additional_headers={"Authorization": f"Bearer {backend.token}"},
                 compression="deflate", **LEGACY)
    try:
        assert ws.protocol.extensions == []
        ws.send(json.dumps({"jsonrpc": "2.0", "id": 1, "method": "ping"}))
        assert json.loads(ws.recv(timeout=10))["result"]["version"]
    finally:
        ws.close()


def test_a_message_above_the_limit_is_answered_and_its_connection_stays(client: RpcClient) -> None:
    """Between the RPC limit and the hard cap: E_TOO_LARGE naming the limit and the size, with the
    request's id unknown (the frame is not parsed), and the same connection answers the next call."""
    frame = json.dumps({"jsonrpc": "2.0", "id": 7, "method": "ping", "x": "a" * LIMIT})
    reply = client.raw(frame)
    assert reply["id"] is None
    assert reply["error"]["data"] == {"code": "E_TOO_LARGE", "limit": LIMIT, "got": len(frame)}
    assert client.call("ping")["version"]
