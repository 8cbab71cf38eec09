"""workspace.warmUp over the real WebSocket: returns at once, refuses bad params, and a generation after it
labels exactly as one without it. planning.warmUp: loads the compiled kernels, after which path checks
give the verdicts they gave before."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from rpc_backend import BackendProcess, RpcClient
from simhelp import KUKA

import robwot_sim.limits


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


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        for task in Path(f"/proc/{p}/task").iterdir():
            kids = [int(k) for k in (task / "children").read_text().split()]
            out += kids
            todo += kids
    return out


def test_warm_up_leaves_the_alpha_shape_code_to_the_generation(tmp_path: Path) -> None:
    """workspace.warmUp starts the workers and loads nothing else: the alpha shape's code (scipy's spatial
    package, whose Qhull library the process then maps) loads once a generation labels, when the backend
    waits for its workers, not while the workers start beside it (every core is busy then)."""
    proc = BackendProcess()
    try:
        c = proc.client()
        assert c.call("workspace.warmUp", {"workers": 2}) == {"workers": 2}
        qhull = lambda: "spatial/_qhull" in Path(f"/proc/{proc.proc.pid}/maps").read_text()  # noqa: E731
        deadline = time.monotonic() + 120
        while len(_descendants(proc.proc.pid)) < 3 and time.monotonic() < deadline:  # forkserver, 2 workers
            time.sleep(0.05)
        assert len(_descendants(proc.proc.pid)) >= 3
        time.sleep(1.0)  # the workers run: an import the warm-up made beside them has ended by now
        assert not qhull()
        c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
        c.call("workspace.generate", {"robot": "kuka", "samples": 500, "workers": 2, "outDir": str(tmp_path)},
               timeout=300)
        assert qhull()
    finally:
        proc.stop()


def test_warm_up_refuses_bad_workers(client: RpcClient) -> None:
    for bad in (0, 1.5, "two", 257):
        err = client.error("workspace.warmUp", {"workers": bad})
        assert err.code == -32602 and err.data["param"] == "workers"


def test_planning_warm_up_keeps_the_path_verdicts() -> None:
    """In a backend of its own (the kernels, once loaded, stay for the process): 30 straight path checks
    among two boxes, before planning.warmUp and after it said the kernels are loaded (asked again until
    it does), give the same verdicts and first contacts."""
    proc = BackendProcess()
    try:
        c = proc.client()
        c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
        for name, where in (("a", [0.45, 0.0, 0.5]), ("b", [0.0, 0.45, 0.3])):
            c.call("obstacle.add", {"name": name, "shape": {"type": "box", "size": [0.1, 0.3, 0.3]},
                                    "position": where})
        rng = np.random.default_rng(8)
        targets = (rng.uniform(-1.0, 1.0, size=(30, 7)) * [2.9, 2.0, 2.9, 2.0, 2.9, 2.0, 3.0]).tolist()

        def verdicts() -> list[tuple[bool, str]]:
            out = []
            for t in targets:
                r = c.call("robot.checkPath", {"robot": "kuka", "target": t})
                out.append((r["collisionFree"], json.dumps(r.get("firstCollision"), sort_keys=True)))
            return out

        before = verdicts()
        assert {free for free, _ in before} == {True, False}  # both verdicts occur
        assert c.call("planning.warmUp", {})["ready"] in (True, False)  # at once, whatever its state
        deadline = time.monotonic() + 900  # a machine's first use compiles the kernels
        while not c.call("planning.warmUp", {})["ready"]:
            assert time.monotonic() < deadline, "the kernels did not load"
            time.sleep(0.2)
        assert verdicts() == before
    finally:
        assert proc.stop() == 0


def test_compile_command_leaves_the_kernels_loadable() -> None:
    """``python -m robwot_sim compile`` (what npm install runs) exits 0 saying the kernels are compiled, and
    leaves the package's bytecode beside its sources (removed first for one module here)."""
    source = Path(robwot_sim.limits.__file__)
    cached = Path(importlib.util.cache_from_source(str(source)))
    cached.unlink(missing_ok=True)
    done = subprocess.run([sys.executable, "-m", "robwot_sim", "compile"], capture_output=True, text=True,
                          timeout=1200, check=False)
    assert done.returncode == 0, done.stderr
    assert "the outer bounds' kernels are compiled" in done.stderr
    assert cached.is_file()
    assert all(Path(importlib.util.cache_from_source(str(f))).is_file() for f in source.parent.rglob("*.py"))


def test_planning_warm_up_spam_starts_one_waiter() -> None:
    """A client asking 300 times while the kernels load starts one background waiter, not 300 threads:
    the backend's thread count stays small and it keeps answering."""
    proc = BackendProcess()
    try:
        c = proc.client()
        c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
        ids = [c.send("planning.warmUp", {}) for _ in range(300)]
        for i in ids:
            c.wait(i, timeout=60)
        status = Path(f"/proc/{proc.proc.pid}/status").read_text()
        threads = int(next(line.split()[1] for line in status.splitlines() if line.startswith("Threads:")))
        assert threads < 40, threads
        assert c.call("ping") is not None
    finally:
        assert proc.stop() == 0
