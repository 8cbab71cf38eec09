"""Shared fixtures of the over-the-wire tests: one real backend process per test module."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from rpc_backend import BackendProcess, RpcClient

# every backend started by the tests checks each of its results against the contract (a result that
# contradicts schemas/protocol.openrpc.json is answered as E_INTERNAL, failing the test)
os.environ["ROBWOT_CHECK_RESULTS"] = "1"


@pytest.fixture(scope="module")
def backend() -> Iterator[BackendProcess]:
    """A real `python -m robwot_sim serve` process; it must exit cleanly (code 0) at the end."""
    proc = BackendProcess()
    yield proc
    assert proc.stop() == 0


@pytest.fixture
def client(backend: BackendProcess) -> Iterator[RpcClient]:
    """A connection to a reset world holding the KUKA iiwa as robot "kuka"."""
    c = backend.client()
    c.call("world.reset")
    c.call("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "kuka"})
    yield c
    c.close()
