"""Seeded fuzzing over the real WebSocket: random params for every method never crash the server and
never produce E_INTERNAL (every bad value is refused with a structured error)."""

from __future__ import annotations

import json
import random
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from rpc_backend import BackendProcess, RpcClient

CALLS = 40
SKIP = {"workspace.generate"}  # slow by design; its params are covered in test_server_workspace.py
VALUES: list[Any] = [None, "NaN", float("inf"), "x", "", -1, 0, 0.5, 1, 3.5, 1e308, True, [], [1, 2, 3],
                     [0.0] * 4, [0.1] * 7, [[1]], {}, {"type": "box"}, {"type": "sphere", "radius": 0.1},
                     {"a": 1}, "kuka", "ball", "../../../../etc/passwd", "kuka_iiwa/model.urdf"]


@pytest.fixture
def client(backend: BackendProcess) -> Iterator[RpcClient]:
    c = backend.client()
    yield c
    c.close()


def _param_names(client: RpcClient, method: str) -> list[str]:
    """The method's params, read from the server's own unknown-param error."""
    err = client.error(method, {"zz_unknown": 1})
    assert err.data["code"] == "E_INVALID_PARAMS"
    return re.findall(r"'(\w+)'", err.data["expected"])


def test_random_params_never_cause_internal_errors(client: RpcClient, tmp_path: Path) -> None:
    """CALLS seeded random calls per method answer a result or a structured, non-internal error."""
    rng = random.Random(1234)
    methods = sorted(set(client.error("nope").data["available"]) - SKIP)
    names = {m: _param_names(client, m) for m in methods}
    for method in methods:
        for _ in range(CALLS):
            world = client.call("world.list")
            if "kuka" not in [r["id"] for r in world["robots"]]:
                client.call("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "kuka"})
            if "ball" not in [o["name"] for o in world["obstacles"]]:
                client.call("obstacle.add", {"name": "ball", "shape": {"type": "sphere", "radius": 0.05},
                                             "position": [1, 1, 1]})
            chosen = rng.sample(names[method], k=rng.randint(0, len(names[method])))
            params = {n: rng.choice(VALUES) for n in chosen}
            if "outDir" in params:
                params["outDir"] = str(tmp_path / "out")
            if "realtime" in params:
                params["realtime"] = 0
            frame = json.dumps({"jsonrpc": "2.0", "id": 1, "method": method, "params": params})
            reply = client.raw(frame.replace('"NaN"', "NaN"))
            if "error" in reply:
                error = reply["error"]
                assert error["data"]["code"] != "E_INTERNAL", (method, params, error)
                assert isinstance(error["code"], int) and error["message"]
            else:
                assert "result" in reply
    client.call("world.reset")
    assert client.call("ping")["version"]
