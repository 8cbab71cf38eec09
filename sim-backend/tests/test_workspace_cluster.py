"""generate_workspace on a Ray cluster (``cluster=ADDRESS``) against the local process pool.

Opt-in: these tests start a local Ray cluster (``ray start --head --block``, 2 worker CPUs) and run only
when ``ROBWOT_RAY_TESTS=1`` (``.ci/run`` sets it, and installs the backend with ``ROBWOT_EXTRAS=cluster``).
With the variable set, a missing Ray is a failure, not a skip.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robwot_sim.errors import InvalidParams, SimError
from robwot_sim.sim.world import World
from robwot_sim.workspace.cluster import LocalCluster
from robwot_sim.workspace.generate import generate_workspace

ENABLED = os.environ.get("ROBWOT_RAY_TESTS") == "1"
pytestmark = pytest.mark.skipif(not ENABLED, reason="Ray cluster tests are opt-in: set ROBWOT_RAY_TESTS=1 "
                                                    "(and install the backend with ROBWOT_EXTRAS=cluster)")
FILES = ("workspace.csv", "workspace.stl", "reachability.csv")
BOX = {"name": "box", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]}, "position": [0.45, 0.0, 0.6]}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, subprocess.Popen[bytes]]]:
    """A local Ray cluster: head node with 2 CPUs, stopped with its processes at the end."""
    import ray  # noqa: F401 - a failure when the tests are enabled without the cluster extra

    with LocalCluster(2, tmp_path_factory.mktemp("ray")) as c:
        yield c.address, c.head


def _generate(out: Path, samples: int, seed: int, cluster: str | None = None, **kw: Any) -> dict[str, Any]:
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="kuka")
        w.add_obstacle(json.loads(json.dumps(BOX)))
        return generate_workspace(w, "kuka", samples=samples, seed=seed, workers=2, out_dir=out,
                                  csv_joints=True, cluster=cluster, **kw)


def _same(a: Path, b: Path, sa: dict[str, Any], sb: dict[str, Any]) -> None:
    for name in FILES:
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
    strip = ("timings",)
    assert {k: v for k, v in sa.items() if k not in strip} == {k: v for k, v in sb.items() if k not in strip}


def test_cluster_gives_the_local_files(cluster: tuple[str, Any], tmp_path: Path) -> None:
    """Same seed and samples: byte-identical CSV (with joints), STL and reachability map, same summary;
    progress counts every sample across the cluster; the obstacle makes the labels matter."""
    address, _ = cluster
    events: list[tuple[str, int, int]] = []
    local = _generate(tmp_path / "local", 3000, 7)
    remote = _generate(tmp_path / "ray", 3000, 7, address, progress=lambda s, d, t: events.append((s, d, t)))
    _same(tmp_path / "local", tmp_path / "ray", local, remote)
    assert 0 < remote["collisionFree"] < 3000
    collide = [(d, t) for s, d, t in events if s == "collide"]
    assert collide[0] == (0, 3000) and collide[-1] == (3000, 3000) and len(collide) > 2
    assert [d for d, _ in collide] == sorted(d for d, _ in collide)
    other = _generate(tmp_path / "other", 3000, 8, address)
    assert other["seed"] == 8
    csv = "workspace.csv"
    assert (tmp_path / "other" / csv).read_bytes() != (tmp_path / "ray" / csv).read_bytes()


def test_cluster_alpha_cap_is_the_first_points(cluster: tuple[str, Any], tmp_path: Path) -> None:
    """Above the cap the alpha shape is built from the first collision-free points in sample order, on a
    cluster as locally (the CSV and the reachability map still hold every sample)."""
    import robwot_sim.workspace.generate as ws  # the cap's one home

    address, _ = cluster
    cap = ws.ALPHA_MAX_POINTS
    ws.ALPHA_MAX_POINTS = 700
    try:
        local = _generate(tmp_path / "local", 2500, 3)
        remote = _generate(tmp_path / "ray", 2500, 3, address)
    finally:
        ws.ALPHA_MAX_POINTS = cap
    _same(tmp_path / "local", tmp_path / "ray", local, remote)
    full = _generate(tmp_path / "full", 2500, 3)
    assert full["volume"] != local["volume"]
    assert full["collisionFree"] == local["collisionFree"] > 700


def test_cluster_retries_a_killed_worker(cluster: tuple[str, subprocess.Popen[bytes]],
                                         tmp_path: Path) -> None:
    """A worker process killed while it runs a chunk: Ray re-runs its chunks and the files are still those
    of the local run."""
    import psutil

    address, head = cluster
    killed: list[int] = []

    def kill_one(stage: str, done: int, total: int) -> None:
        if stage != "collide" or killed or done == 0:
            return
        for p in psutil.Process(head.pid).children(recursive=True):
            try:
                if p.name().startswith("ray::label_chunk") or "ray::label_chunk" in " ".join(p.cmdline()):
                    p.kill()
                    killed.append(p.pid)
                    return
            except psutil.Error:
                continue

    local = _generate(tmp_path / "local", 12_000, 11)
    remote = _generate(tmp_path / "ray", 12_000, 11, address, progress=kill_one)
    assert killed, "no running chunk task was found to kill"
    _same(tmp_path / "local", tmp_path / "ray", local, remote)


def test_cluster_refuses_bad_address(tmp_path: Path) -> None:
    """An empty address is a parameter error; an address where no cluster answers an E_CLUSTER error."""
    with pytest.raises(InvalidParams):
        _generate(tmp_path, 100, 1, "  ")
    with pytest.raises(SimError) as e:
        _generate(tmp_path, 100, 1, f"127.0.0.1:{_free_port()}")
    assert e.value.code == "E_CLUSTER"


def test_no_cluster_needs_no_ray(tmp_path: Path) -> None:
    """The local run never imports Ray."""
    code = ("import sys, json; from robwot_sim.sim.world import World; "
            "from robwot_sim.workspace.generate import generate_workspace; w = World(); "
            "w.load_robot('kuka_iiwa/model.urdf', robot_id='kuka'); "
            f"generate_workspace(w, 'kuka', samples=600, seed=1, workers=1, out_dir={str(tmp_path)!r}); "
            "print(json.dumps('ray' in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "false"
    assert np.loadtxt(tmp_path / "workspace.csv", delimiter=",", skiprows=1).shape == (600, 4)
