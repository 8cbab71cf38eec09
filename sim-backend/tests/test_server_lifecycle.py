"""`python -m robwot_sim serve`: the ready line, clean exit on signals, survival of misbehaving clients."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys

import pytest
from rpc_backend import BackendProcess, RpcClient


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_ready_line_and_clean_exit(sig: int) -> None:
    """Stdout carries exactly one JSON ready line with the bound port; a signal exits with code 0."""
    backend = BackendProcess()
    assert json.loads(backend.ready_line) == {"event": "ready", "port": backend.port}
    assert backend.ready_line == json.dumps({"event": "ready", "port": backend.port},
                                            separators=(",", ":")) + "\n"
    client = backend.client()
    client.call("robot.load", {"urdf": "kuka_iiwa/model.urdf"})
    assert backend.proc.stdout is not None
    assert backend.stop(sig) == 0
    assert backend.proc.stdout.closed


def test_exit_during_motion_is_clean() -> None:
    """SIGTERM while a motion runs stops it and exits with code 0."""
    backend = BackendProcess()
    client = backend.client()
    client.call("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "k"})
    client.send("robot.move", {"robot": "k", "target": [2.0, 0, 0, 0, 0, 0, 0], "speed": 0.05})
    client.wait_notification("robot.state")
    assert backend.stop() == 0


def test_stdout_is_only_the_ready_line() -> None:
    """Nothing but the ready line reaches stdout, even after loading robots (Bullet prints go to stderr)."""
    backend = BackendProcess()
    client = backend.client()
    client.call("robot.load", {"urdf": "franka_panda/panda.urdf"})
    client.close()
    assert backend.proc.stdout is not None
    stdout = backend.proc.stdout
    backend.proc.send_signal(signal.SIGTERM)
    assert backend.proc.wait(15) == 0
    assert stdout.read() == b""


def test_port_in_use_fails_with_message() -> None:
    """A port already taken makes serve exit non-zero with the reason on stderr, without a ready line."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        port = sock.getsockname()[1]
        proc = subprocess.run([sys.executable, "-m", "robwot_sim", "serve", "--port", str(port)],
                              capture_output=True, timeout=60, check=False)
    assert proc.returncode != 0
    assert proc.stdout == b""
    assert str(port) in proc.stderr.decode()


def test_survives_abrupt_disconnects_and_raw_garbage() -> None:
    """Clients vanishing mid-motion or sending non-WebSocket bytes do not take the server down."""
    backend = BackendProcess()
    c1 = backend.client()
    c1.call("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "k"})
    c1.send("robot.move", {"robot": "k", "target": [1.0, 0, 0, 0, 0, 0, 0], "speed": 0.1})
    c1.ws.socket.close()
    with socket.create_connection(("127.0.0.1", backend.port)) as raw:
        raw.sendall(b"\x00\xff garbage\r\n\r\n")
    c2 = backend.client()
    assert c2.call("ping")["version"]
    # a motion outlives the connection that started it: stop it from another client
    assert c2.call("robot.stop", {"robot": "k"}) == {"stopped": True}
    assert c2.call("robot.move", {"robot": "k", "target": [0.0] * 7, "realtime": 0})["status"] == "reached"
    c2.close()
    assert backend.stop() == 0


def test_exit_on_stdin_eof() -> None:
    """With --exit-on-stdin-eof the server exits cleanly once its stdin pipe closes (launcher died)."""
    backend = BackendProcess("--exit-on-stdin-eof", stdin=subprocess.PIPE)
    client = backend.client()
    assert client.call("ping")["version"]
    assert backend.proc.stdin is not None
    backend.proc.stdin.close()
    assert backend.proc.wait(15) == 0


def test_only_the_owner_is_served() -> None:
    """Without the token, with a wrong one, or from a browser (Origin header) the upgrade is refused
    (401/403) and no method runs; with the token the connection works."""
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    backend = BackendProcess()
    try:
        cases = [({}, 401), ({"Authorization": "Bearer wrong"}, 401),
                 ({"Authorization": f"Bearer {backend.token}", "Origin": "http://evil.example"}, 403)]
        for headers, status in cases:
            with pytest.raises(InvalidStatus) as info:
                connect(backend.url, additional_headers=headers, open_timeout=10)
            assert info.value.response.status_code == status
        client = backend.client()
        assert client.call("ping")["version"]
        client.close()
    finally:
        backend.stop()


def test_a_backend_started_without_token_makes_one_and_names_it_in_the_ready_line() -> None:
    """`python -m robwot_sim serve` by hand: a random token, given once on stdout to whoever started it."""
    import os

    env = {k: v for k, v in os.environ.items() if k != "ROBWOT_BACKEND_TOKEN"}
    proc = subprocess.Popen([sys.executable, "-m", "robwot_sim", "serve", "--port", "0"],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    try:
        assert proc.stdout is not None
        ready = json.loads(proc.stdout.readline())
        assert len(ready["token"]) >= 32
        client = RpcClient(f"ws://127.0.0.1:{ready['port']}", ready["token"])
        assert client.call("ping")["version"]
        client.close()
    finally:
        proc.terminate()
        proc.wait(15)


def _rss_kb(pid: int) -> int:
    with open(f"/proc/{pid}/status") as f:
        return int(next(line for line in f if line.startswith("VmRSS")).split()[1])


def test_obstacle_add_remove_does_not_grow_the_backend() -> None:
    """2,000 add/remove pairs of an obstacle leave the backend's memory flat (PyBullet keeps ~3.5 KB per
    removed body: removed obstacles are parked and reused)."""
    backend = BackendProcess()
    client = backend.client()
    try:
        client.call("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "kuka"})
        box = {"name": "crate", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]}, "position": [0.5, 0, 0.5]}
        for _ in range(200):  # warm up allocator pools
            client.call("obstacle.add", box)
            client.call("obstacle.remove", {"name": "crate"})
        before = _rss_kb(backend.proc.pid)
        for i in range(2000):
            client.call("obstacle.add", {**box, "position": [0.5, 0, 0.5 + (i % 7) * 0.01]})
            client.call("robot.checkCollision", {"robot": "kuka"})
            client.call("obstacle.remove", {"name": "crate"})
        grown = _rss_kb(backend.proc.pid) - before
        assert grown < 1500, f"backend grew {grown} KB over 2,000 add/remove pairs"
        # a parked obstacle takes no part in checks; a re-added one does
        assert client.call("robot.checkCollision", {"robot": "kuka"})["collisionFree"]
        big = {"type": "box", "size": [0.3] * 3}
        client.call("obstacle.add", {**box, "position": [0, 0, 0.5], "shape": big})
        assert not client.call("robot.checkCollision", {"robot": "kuka"})["collisionFree"]
    finally:
        client.close()
        backend.stop()


def test_help_explains_the_token() -> None:
    """`serve --help` says how the token is given (environment) and where a made one is printed."""
    out = subprocess.run([sys.executable, "-m", "robwot_sim", "serve", "--help"], capture_output=True,
                         text=True, check=True).stdout
    assert "ROBWOT_BACKEND_TOKEN" in out and "ready line" in out and "Origin" in out
