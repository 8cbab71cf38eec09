"""workspace.generate over the real WebSocket: runs in the background, progress to the caller only."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from rpc_backend import BackendProcess, RpcClient


def test_generate_streams_progress_and_serves_meanwhile(backend: BackendProcess, client: RpcClient,
                                                        tmp_path: Path) -> None:
    """Progress goes to the caller only; ping is answered before the generation ends; files are written."""
    other = backend.client()
    other.call("ping")
    job = client.send("workspace.generate", {"robot": "kuka", "samples": 3000, "seed": 7, "workers": 2,
                                             "outDir": str(tmp_path)})
    ping = client.send("ping")
    first = client.wait_notification("workspace.progress")
    assert first["stage"] == "sample"
    assert client.wait(ping)["version"]
    assert job not in client.replies  # the generation was still running when ping answered
    summary = client.wait(job, timeout=300)
    assert summary["samples"] == 3000 and summary["seed"] == 7
    assert 0 < summary["collisionFree"] <= 3000
    assert summary["method"] in ("alpha-shape", "convex-hull")
    stages = [p["stage"] for m, p in client.notifications if m == "workspace.progress"]
    assert {"collide", "alpha", "write"} <= set(stages)
    lines = (tmp_path / "workspace.csv").read_text().splitlines()
    assert len(lines) == 3001
    assert (tmp_path / "workspace.stl").stat().st_size > 84
    other_progress = [m for m, _ in other.notifications if m == "workspace.progress"]
    assert other.call("ping")["version"] and other_progress == []
    other.close()
    json.dumps(summary)


@pytest.mark.parametrize(("params", "param"), [
    ({"samples": 0}, "samples"), ({"samples": 1.5}, "samples"), ({"alpha": "big"}, "alpha"),
    ({"alpha": -1}, "alpha"), ({"workers": 0}, "workers"), ({"csvJoints": "yes"}, "csvJoints"),
    ({"cluster": ""}, "cluster"), ({"cluster": "   "}, "cluster"), ({"cluster": 7}, "cluster"),
])
def test_invalid_params_are_refused(client: RpcClient, tmp_path: Path, params: dict[str, object],
                                    param: str) -> None:
    """Bad generation params are -32602 naming the param, and nothing is written."""
    err = client.error("workspace.generate", {"robot": "kuka", "outDir": str(tmp_path / "out"), **params})
    assert err.code == -32602 and err.data["param"] == param
    assert not (tmp_path / "out").exists()


def test_cluster_where_none_answers(client: RpcClient, tmp_path: Path) -> None:
    """``cluster`` at an address where nothing listens: E_CLUSTER at once (with Ray installed) or
    E_INVALID_PARAMS naming the missing extra (without)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    err = client.error("workspace.generate", {"robot": "kuka", "samples": 500, "outDir": str(tmp_path),
                                              "cluster": f"127.0.0.1:{port}"})
    try:
        import ray  # noqa: F401
        assert err.data["code"] == "E_CLUSTER" and f"127.0.0.1:{port}" in str(err)
    except ImportError:
        assert err.code == -32602 and err.data["param"] == "cluster" and "extra" in str(err)
