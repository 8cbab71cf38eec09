"""workspace.warmUp over the real WebSocket: returns at once, refuses bad params, and a generation after it
labels exactly as one without it."""

from __future__ import annotations

from pathlib import Path

from rpc_backend import RpcClient

import robwot_sim.scene as scene
from robwot_sim.workspace.pool import _validated_spec


def test_warm_up_then_generate_gives_the_same_csv(client: RpcClient, tmp_path: Path) -> None:
    """The warmed-up pool labels like the pool a generation starts itself (same seed => same CSV)."""
    params = {"robot": "kuka", "samples": 2000, "seed": 3, "workers": 2}
    cold = client.call("workspace.generate", {**params, "outDir": str(tmp_path / "cold")}, timeout=300)
    assert client.call("workspace.warmUp", {"workers": 2}) == {"workers": 2}
    assert client.call("workspace.warmUp", {"workers": 2}) == {"workers": 2}  # again: harmless
    warm = client.call("workspace.generate", {**params, "outDir": str(tmp_path / "warm")}, timeout=300)
    assert warm["collisionFree"] == cold["collisionFree"]
    csv = [(tmp_path / d / "workspace.csv").read_text() for d in ("cold", "warm")]
    assert csv[0] == csv[1]


def test_warm_up_refuses_bad_workers(client: RpcClient) -> None:
    for bad in (0, 1.5, "two", 257):
        err = client.error("workspace.warmUp", {"workers": bad})
        assert err.code == -32602 and err.data["param"] == "workers"


def test_validated_spec_restores_the_schema_check() -> None:
    """Workers skip the schema check only while loading the already validated spec."""
    original = scene.schema_errors
    with _validated_spec():
        assert scene.schema_errors({"version": "bad"}) is None
    assert scene.schema_errors is original
    assert scene.schema_errors({"version": "bad"}) is not None
