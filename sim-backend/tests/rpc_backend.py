"""Test support: a real `python -m robwot_sim serve` process and a plain synchronous WebSocket client."""

from __future__ import annotations

import json
import os
import secrets
import signal
import subprocess
import sys
import tempfile
import time
from typing import Any

import websockets
from websockets.sync.client import ClientConnection, connect

from robwot_sim.rpc.contract import contract

# websockets >= 16 asks direct connections to say so (no proxy lookup); 15.0.1, which wotpy's MQTT
# dependency pins in the test environment, has no such flag
LEGACY = {"legacy": True} if int(websockets.__version__.split(".")[0]) >= 16 else {}

READY_TIMEOUT = 60.0


class BackendProcess:
    """`python -m robwot_sim serve --port 0` with stderr captured to a file."""

    def __init__(self, *args: str, stdin: int = subprocess.DEVNULL) -> None:
        self.stderr_file = tempfile.TemporaryFile()  # noqa: SIM115 - lives as long as the process
        self.token = secrets.token_urlsafe(16)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "robwot_sim", "serve", "--port", "0", *args],
            stdout=subprocess.PIPE, stderr=self.stderr_file, stdin=stdin,
            env={**os.environ, "PYTHONUNBUFFERED": "1", "ROBWOT_BACKEND_TOKEN": self.token},
        )
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline().decode()
        if not line:
            raise RuntimeError(f"backend exited before ready: {self.stderr()}")
        self.ready_line = line
        self.port = int(json.loads(line)["port"])
        self.url = f"ws://127.0.0.1:{self.port}"

    def stderr(self) -> str:
        self.stderr_file.seek(0)
        return self.stderr_file.read().decode(errors="replace")[-4000:]

    def client(self) -> RpcClient:
        return RpcClient(self.url, self.token)

    def stop(self, sig: int = signal.SIGTERM, timeout: float = 15.0) -> int:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        code = self.proc.wait(timeout)
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self.stderr_file.close()
        return code


def _check_error(reply: dict[str, Any]) -> None:
    """An error reply carries a data.code the contract lists, under its JSON-RPC number."""
    error = reply.get("error")
    if error is None:
        return
    known = contract().document["components"]["errors"]
    code = error.get("data", {}).get("code")
    assert code in known, f"error code {code!r} is not in the contract"
    expected = known[code]["code"]
    assert expected == error["code"], f"{code} answered as {error['code']}, contract: {expected}"


class RpcError(Exception):
    def __init__(self, error: dict[str, Any]) -> None:
        super().__init__(error.get("message"))
        self.error = error
        self.code: int = error["code"]
        self.data: dict[str, Any] = error.get("data", {})


class RpcClient:
    """Plain JSON-RPC over a sync WebSocket; keeps the notifications seen while waiting for replies."""

    def __init__(self, url: str, token: str) -> None:
        auth = {"Authorization": f"Bearer {token}"}
        self.ws: ClientConnection = connect(url, max_size=None, open_timeout=20, additional_headers=auth,
                                            **LEGACY)
        self.notifications: list[tuple[str, dict[str, Any]]] = []
        self.replies: dict[Any, dict[str, Any]] = {}
        self._next = 1

    def close(self) -> None:
        self.ws.close()

    def _notified(self, doc: dict[str, Any]) -> None:
        """Keep a notification, after checking it against the contract's `x-notifications`."""
        problem = contract().check_notification(doc["method"], doc["params"])
        assert problem is None, f"{doc['method']} contradicts the contract: {problem}"
        self.notifications.append((doc["method"], doc["params"]))

    def send(self, method: str, params: dict[str, Any] | None = None) -> int:
        req_id = self._next
        self._next += 1
        msg: dict[str, Any] = {"jsonrpc": "2.0", "id": req_id, "method": method}
        if params is not None:
            msg["params"] = params
        self.ws.send(json.dumps(msg))
        return req_id

    def raw(self, frame: str | bytes, timeout: float = 30.0) -> dict[str, Any]:
        """Send a raw frame and return the next reply (any id)."""
        self.ws.send(frame)
        return self._next_reply(timeout)

    def _next_reply(self, timeout: float) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            doc = json.loads(self.ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if "id" in doc:
                _check_error(doc)
                return dict(doc)
            self._notified(doc)

    def wait(self, req_id: int, timeout: float = 60.0) -> dict[str, Any]:
        """The reply to `req_id` (raises RpcError on an error reply)."""
        deadline = time.monotonic() + timeout
        while req_id not in self.replies:
            reply = self._next_reply(deadline - time.monotonic())
            self.replies[reply["id"]] = reply
        reply = self.replies.pop(req_id)
        if "error" in reply:
            raise RpcError(reply["error"])
        return dict(reply["result"])

    def call(self, method: str, params: dict[str, Any] | None = None,
             timeout: float = 60.0) -> dict[str, Any]:
        return self.wait(self.send(method, params), timeout)

    def error(self, method: str, params: dict[str, Any] | None = None) -> RpcError:
        """Call expecting an error; returns it."""
        try:
            result = self.call(method, params)
        except RpcError as err:
            return err
        raise AssertionError(f"{method} succeeded unexpectedly: {result}")

    def wait_notification(self, method: str, timeout: float = 30.0) -> dict[str, Any]:
        """The first notification of `method` (replies arriving meanwhile are kept for `wait`)."""
        deadline = time.monotonic() + timeout
        while True:
            for i, (m, p) in enumerate(self.notifications):
                if m == method:
                    del self.notifications[i]
                    return p
            doc = json.loads(self.ws.recv(timeout=max(0.01, deadline - time.monotonic())))
            if "id" in doc:
                self.replies[doc["id"]] = doc
            else:
                self._notified(doc)
