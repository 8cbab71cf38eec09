"""Workspace generation on a Ray cluster (``generate --cluster ADDRESS``; the optional ``cluster`` extra).

The driver (this process) connects to an existing cluster (``ray://host:10001``, or ``auto``: the address
in ``RAY_ADDRESS`` or the cluster started on this machine), puts the shared ``ChunkJob`` once into the
object store and runs one task per chunk (``chunk.label_chunk``): each task draws its rows from the seed,
computes FK, labels them in its worker process's cached world (``pool.worker_label``: one World per
worker process, rebuilt only when the scene changes) and formats its CSV lines.

Bounded memory: at most ``WINDOW_PER_CPU`` tasks per cluster CPU are in flight; finished chunks are
written to ``workspace.csv`` in chunk order as soon as they are contiguous, their reachability counts are
merged and their collision-free points kept for the alpha shape only up to ``ALPHA_MAX_POINTS``
(``__init__.py``; the first ones in sample order: the samples are i.i.d., so that is a uniform
subsample; runs below the cap are unaffected). The driver never holds all rows.

Retries: a task whose worker process or node dies is re-run by Ray (``max_retries=MAX_RETRIES``); the chunk
depends only on ``(seed, rows)``, so the retry gives the same rows.

The URDF, mesh and scene files are read by the workers at the paths of the driver's scene: on a multi-node
cluster they must be on a shared file system (or the same image), and ``robwot-sim`` must be installed on
the nodes (README "Running on a Ray cluster").
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import ClusterError, InvalidParams
from robwot_sim.wholefile import atomic_write
from robwot_sim.workspace.chunk import ChunkJob, ChunkSink, label_chunk
from robwot_sim.workspace.labelling import chunk_size, rebuild_error
from robwot_sim.workspace.reachability import ReachabilityMap

FloatArray = npt.NDArray[np.float64]

MAX_RETRIES = 4
WINDOW_PER_CPU = 3
CONNECT_TIMEOUT = 10.0

_lock = threading.Lock()
_connected: str | None = None
_remote: Any = None


def _ray() -> Any:
    try:
        import ray
    except ImportError:
        raise InvalidParams("cluster needs Ray: install the backend with the cluster extra "
                            "(ROBWOT_EXTRAS=cluster npm install, or pip install 'robwot-sim[cluster]')",
                            param="cluster", expected="Ray installed", got=None) from None
    return ray


def _check_reachable(address: str) -> None:
    """Fail fast (``E_CLUSTER``) when nothing listens at a ``[ray://]host:port`` address: ``ray.init``
    itself retries for minutes. ``auto`` is left to Ray (it fails at once when no cluster is found)."""
    if address == "auto":
        return
    rest = address.split("://", 1)[1] if "://" in address else address
    host, sep, port = rest.rstrip("/").rpartition(":")
    if not sep or not port.isdigit():
        raise InvalidParams(f"cluster address {address!r} is not auto, ray://host:port or host:port",
                            param="cluster", expected='"auto" | "ray://host:port" | "host:port"', got=address)
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=CONNECT_TIMEOUT):
            pass
    except OSError as e:
        raise ClusterError(f"cannot connect to the Ray cluster at {address!r}: {e.strerror or e}",
                           address=address) from None


def connect(address: str) -> Any:
    """Connect this process to the Ray cluster at ``address`` (once; again when the address changes).
    Returns the ``ray`` module."""
    global _connected, _remote
    if not isinstance(address, str) or not address:
        raise InvalidParams('cluster must be a Ray address ("auto" or ray://host:port)', param="cluster",
                            expected='"auto" | "ray://host:port" | "host:port"', got=address)
    ray = _ray()
    _check_reachable(address)
    with _lock:
        if _connected != address or not ray.is_initialized():
            if ray.is_initialized():
                ray.shutdown()
            try:
                ray.init(address=address, logging_level="WARNING", log_to_driver=False,
                         configure_logging=False)
            except (ConnectionError, RuntimeError, ValueError) as e:
                raise ClusterError(f"cannot connect to the Ray cluster at {address!r}: {e}",
                                   address=address) from None
            _connected = address
            _remote = ray.remote(num_cpus=1, max_retries=MAX_RETRIES)(label_chunk)
    return ray


def cluster_cpus(ray: Any) -> int:
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


@dataclass
class ClusterRun:
    """What the driver keeps of a cluster run."""

    samples: int
    collision_free: int
    alpha_points: FloatArray  # collision-free points for the alpha shape (at most alpha_max_points)
    lo: FloatArray | None  # bounds of every collision-free point
    hi: FloatArray | None
    reach: ReachabilityMap
    seconds: float


def run_chunks(address: str, job: ChunkJob, samples: int, header: list[str], csv_path: Path,
               progress: Callable[[int, int], None], alpha_max_points: int) -> ClusterRun:
    """Run every chunk of ``samples`` rows on the cluster; write ``workspace.csv`` (``header`` then the
    rows in order) while they arrive, keeping the first ``alpha_max_points`` collision-free points.
    ``progress(done, total)`` counts finished rows across the cluster."""
    ray = connect(address)
    t0 = time.perf_counter()
    cpus = cluster_cpus(ray)
    size = chunk_size(samples, cpus)
    chunks = [(a, min(size, samples - a)) for a in range(0, samples, size)]
    window = max(2, WINDOW_PER_CPU * cpus)
    job_ref = ray.put(job)
    done = 0
    sink = ChunkSink(job.voxel, alpha_max_points, lambda _b: None)

    def write(f: BinaryIO) -> None:
        nonlocal done
        f.write((",".join(header) + "\n").encode())
        sink.write = f.write
        pending: dict[Any, int] = {}
        submitted = 0
        try:
            while sink.folded < len(chunks):
                while submitted < len(chunks) and submitted - sink.folded < window:
                    a, n = chunks[submitted]
                    pending[_remote.remote(job_ref, a, n)] = submitted
                    submitted += 1
                ready, _ = ray.wait(list(pending), num_returns=1)
                for ref in ready:
                    i = pending.pop(ref)
                    res = ray.get(ref)
                    if isinstance(res, dict):
                        raise rebuild_error(res)
                    sink.add(i, res)
                    done += res.count
                progress(done, samples)
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=False)
            raise

    atomic_write(csv_path, write)
    return ClusterRun(samples, sink.free, sink.alpha_points(), sink.lo, sink.hi, sink.reach,
                      time.perf_counter() - t0)


def cluster_address(value: Any) -> str | None:
    """The ``cluster`` parameter: ``None`` (local pool), ``"auto"`` or a Ray address."""
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise InvalidParams('cluster must be a Ray address ("auto" or ray://host:port)', param="cluster",
                            expected='"auto" | "ray://host:port" | "host:port"', got=value)
    return value.strip()


class LocalCluster:
    """A Ray cluster on this machine for tests and benchmarks: ``ray start --head --block`` with ``cpus``
    worker CPUs, its files under ``temp_dir``; ``stop()`` (or leaving the ``with`` block) ends it and every
    process it started (``--block``: the command stops them when terminated), nothing else."""

    def __init__(self, cpus: int, temp_dir: str | Path, timeout: float = 120.0) -> None:
        ray_bin = Path(sys.executable).parent / "ray"
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            self.port = int(s.getsockname()[1])
        self.address = f"127.0.0.1:{self.port}"
        temp = Path(temp_dir)
        temp.mkdir(parents=True, exist_ok=True)
        self.log = temp / "ray-head.log"
        with self.log.open("wb") as log:
            self.head = subprocess.Popen(
                [str(ray_bin), "start", "--head", "--block", f"--port={self.port}", f"--num-cpus={cpus}",
                 "--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp.resolve()}"],
                stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                env={**os.environ, "RAY_USAGE_STATS_ENABLED": "0"})
        deadline = time.monotonic() + timeout
        while True:
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=1):
                    return
            except OSError:
                if self.head.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise RuntimeError(f"ray start failed: {self.log.read_text()[-2000:]}") from None
                time.sleep(0.5)

    def stop(self) -> None:
        """Disconnect this process if it is connected to this cluster, then stop the cluster."""
        global _connected
        if _connected == self.address:
            import ray

            ray.shutdown()
            _connected = None
        if self.head.poll() is None:
            self.head.terminate()
            try:
                self.head.wait(60)
            except subprocess.TimeoutExpired:
                self.head.kill()
                self.head.wait()

    def __enter__(self) -> LocalCluster:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()
