"""Parallel collision labelling of joint configurations, one PyBullet world per worker process.

PyBullet clients cannot be shared across ``fork``, so workers come from a ``forkserver`` (a clean
process, started once, that has already imported numpy, pybullet and the simulation core): forking a
worker from it costs milliseconds instead of a fresh interpreter's import time. The pool stays alive
between calls; each worker rebuilds its world from the main world's ``scene_spec()`` (obstacles and
every robot, with their base poses and joint positions) and keeps it while the spec is unchanged, so a
second generation in the same backend skips the rebuild. Work is split in chunks for progress
reporting and load balance; the calling process may label chunks too (``helper``) while it would
otherwise wait, which hides the workers' start-up.
"""

from __future__ import annotations

import atexit
import hashlib
import json
import math
import multiprocessing
import os
import threading
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InternalError, SimError

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

MIN_CHUNK = 500
MAX_CHUNK = 4000
CHUNKS_PER_WORKER = 16
HELPER_STEP = 250
_PRELOAD = ["robwot_sim.workspace.labelling", "robwot_sim.sim.world"]

_pool_lock = threading.Lock()
_pools: dict[int, ProcessPoolExecutor] = {}  # by worker count
_active: dict[int, int] = {}  # running labellings per pool

# worker-process state: (spec key, World)
_worker_world: tuple[str, Any] | None = None


def _file_stamps(spec: dict[str, Any]) -> list[list[Any]]:
    """(path, size, mtime) of the URDF and mesh files a scene refers to: an edited file is a new world."""
    paths = [str(r.get("urdf", "")) for r in spec.get("robots", [])]
    paths += [str(o["shape"]["file"]) for o in spec.get("obstacles", [])
              if isinstance(o.get("shape"), dict) and "file" in o["shape"]]
    stamps: list[list[Any]] = []
    for p in paths:
        try:
            st = os.stat(p)
            stamps.append([p, st.st_size, st.st_mtime_ns])
        except OSError:
            stamps.append([p, None, None])
    return stamps


def spec_key(spec: dict[str, Any]) -> str:
    """Stable digest of a scene document and its files' stamps (identifies a worker's cached world)."""
    text = json.dumps([spec, _file_stamps(spec)], sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _worker_label(key: str, spec: dict[str, Any], robot_id: str, qs: FloatArray) -> Any:
    """Runs in a worker: label ``qs`` in the cached world (built from ``spec`` when the key changed).

    Returns the flag array, or an error dict (``SimError`` subclasses do not all survive pickling).
    """
    global _worker_world
    try:
        if _worker_world is None or _worker_world[0] != key:
            from robwot_sim.sim.world import World

            if _worker_world is not None:
                _worker_world[1].close()
                _worker_world = None
            world = World()
            try:
                world.load_scene(spec)
            except BaseException:
                world.close()
                raise
            _worker_world = (key, world)
        flags: BoolArray = _worker_world[1].collision_free_batch(robot_id, qs)
        return flags
    except SimError as e:
        return {"error": e.to_json(), "type": type(e).__name__}


def _ping() -> int:
    return os.getpid()


def _acquire_pool(workers: int) -> ProcessPoolExecutor:
    """The pool of ``workers`` processes (started on first use). Idle pools of other sizes are stopped;
    busy ones are left to finish. Pair with ``_release_pool``."""
    with _pool_lock:
        for size in [k for k in _pools if k != workers and _active.get(k, 0) == 0]:
            _pools.pop(size).shutdown(wait=False, cancel_futures=True)
        pool = _pools.get(workers)
        if pool is None:
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(_PRELOAD)
            pool = _pools[workers] = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        _active[workers] = _active.get(workers, 0) + 1
        return pool


def _release_pool(workers: int, broken: bool = False) -> None:
    with _pool_lock:
        _active[workers] = max(0, _active.get(workers, 0) - 1)
        if broken and workers in _pools:
            _pools.pop(workers).shutdown(wait=False, cancel_futures=True)


def shutdown_pool() -> None:
    """Stop every worker process (also registered with ``atexit``)."""
    with _pool_lock:
        pools = list(_pools.values())
        _pools.clear()
    for pool in pools:
        pool.shutdown(wait=True, cancel_futures=True)


atexit.register(shutdown_pool)


def warm_up(workers: int | None = None) -> threading.Thread:
    """Start the forkserver and ``workers`` (default: cores) worker processes in a background thread,
    e.g. when the backend starts, so the first generation does not pay for it. Returns the thread."""
    n = workers or os.cpu_count() or 1

    def run() -> None:
        pool = _acquire_pool(n)
        try:
            wait([pool.submit(_ping) for _ in range(n)])
        except (BrokenProcessPool, RuntimeError):
            pass  # a later generation reports the problem
        finally:
            _release_pool(n)

    thread = threading.Thread(target=run, name="robwot-workspace-warm-up", daemon=True)
    thread.start()
    return thread


def chunk_size(n: int, workers: int) -> int:
    return max(MIN_CHUNK, min(MAX_CHUNK, math.ceil(n / (workers * CHUNKS_PER_WORKER))))


class Labelling:
    """One labelling job. The pool is started and the chunks submitted by a background thread, so the
    caller can compute FK and label chunks itself (``result(helper=...)``) in the meantime: chunks are
    claimed from the end by the caller, submitted from the start to the workers. If the pool fails to
    start, a helping caller labels everything itself."""

    def __init__(self, spec: dict[str, Any], robot_id: str, qs: FloatArray, workers: int) -> None:
        self.n, self.qs, self.workers = len(qs), qs, workers
        self.spec, self.robot_id, self.key = spec, robot_id, spec_key(spec)
        size = chunk_size(self.n, workers)
        self.chunks = [(a, min(a + size, self.n)) for a in range(0, self.n, size)]
        self._lock = threading.Lock()
        self._taken: set[int] = set()  # claimed by the caller
        self._futures: dict[int, Future[Any]] = {}  # submitted to the pool (not cancelled)
        self._stopped = False
        self._error: BaseException | None = None
        self.pool = _acquire_pool(workers)
        self._released = False
        self._submitter = threading.Thread(target=self._submit_all, name="robwot-labelling-submit",
                                           daemon=True)
        self._submitter.start()

    def _submit_all(self) -> None:
        try:
            self.pool.submit(_ping)  # starts the forkserver and the workers: the slow part
            for i, (a, b) in enumerate(self.chunks):
                with self._lock:
                    if self._stopped:
                        return
                    if i not in self._taken:
                        self._futures[i] = self.pool.submit(_worker_label, self.key, self.spec, self.robot_id,
                                                            np.ascontiguousarray(self.qs[a:b]))
        except (BrokenProcessPool, RuntimeError) as e:
            self._error = e

    def _claim(self) -> int | None:
        """The last chunk no worker has started, now the caller's (cancelled in the pool if queued)."""
        with self._lock:
            for i in range(len(self.chunks) - 1, -1, -1):
                if i in self._taken:
                    continue
                f = self._futures.get(i)
                if f is None or f.cancel():
                    self._futures.pop(i, None)
                    self._taken.add(i)
                    return i
        return None

    def _stop(self, broken: bool = False) -> None:
        with self._lock:
            self._stopped = True
            for f in self._futures.values():
                f.cancel()
        if not self._released:
            self._released = True
            _release_pool(self.workers, broken)

    def abandon(self) -> None:
        """Stop submitting, cancel what no worker has started and release the pool."""
        self._stop()

    def result(self, progress: Callable[[int, int], None] | None = None,
               helper: Callable[[FloatArray], BoolArray] | None = None) -> BoolArray:
        """Wait for every chunk; ``progress(done, total)`` after each. Releases the pool.

        ``helper`` (e.g. the calling process's own ``World.collision_free_batch``) labels chunks that no
        worker has started, from the end, ``HELPER_STEP`` rows per call (short lock holds). If the pool
        breaks (a worker crashed, or workers cannot start, e.g. ``__main__`` read from stdin), the
        helper labels the remaining chunks; without a helper that is an ``InternalError``.
        """
        out = np.zeros(self.n, dtype=bool)
        finished: set[int] = set()  # chunks whose labels are in ``out``
        progress = progress or (lambda _d, _t: None)

        def own(i: int) -> None:
            assert helper is not None
            a, b = self.chunks[i]
            for s in range(a, b, HELPER_STEP):
                e = min(s + HELPER_STEP, b)
                out[s:e] = helper(self.qs[s:e])
            finished.add(i)

        def collect(futures: dict[int, Future[Any]]) -> None:
            for i, f in futures.items():
                if i in finished or not f.done():
                    continue
                res = f.result()
                if isinstance(res, dict):
                    raise _rebuild_error(res)
                a, b = self.chunks[i]
                out[a:b] = res
                finished.add(i)

        def count() -> int:
            return sum(self.chunks[i][1] - self.chunks[i][0] for i in finished)

        broken = False
        try:
            try:
                while helper is not None and (i := self._claim()) is not None:
                    own(i)
                    with self._lock:
                        snapshot = dict(self._futures)
                    collect(snapshot)
                    progress(count(), self.n)
                self._submitter.join()
                if any(i not in self._taken and i not in self._futures for i in range(len(self.chunks))):
                    raise BrokenProcessPool(f"the collision worker pool could not start ({self._error!r})")
                pending = {f for i, f in self._futures.items() if i not in finished}
                while pending:
                    _, pending = wait(pending, return_when=FIRST_COMPLETED)
                    collect(self._futures)
                    progress(count(), self.n)
            except (BrokenProcessPool, CancelledError) as e:
                broken = True
                if helper is None:
                    raise InternalError(f"collision workers failed ({e}); PyBullet crash, out of memory or "
                                        "shutdown") from None
                self._stop(broken)
                for i in range(len(self.chunks)):
                    if i not in finished:
                        own(i)
                        progress(count(), self.n)
        finally:
            self._stop(broken)
        return out


def _rebuild_error(res: dict[str, Any]) -> SimError:
    err = res["error"]
    data = dict(err.get("data", {}))
    code = data.pop("code", "E_INTERNAL")
    e = SimError(f"collision worker: {err.get('message', '')}", code=code, **data)
    e.rpc_code = int(err.get("code", -32603))
    return e


def label_configurations(spec: dict[str, Any], robot_id: str, qs: FloatArray, workers: int,
                         progress: Callable[[int, int], None] | None = None,
                         helper: Callable[[FloatArray], BoolArray] | None = None) -> BoolArray:
    """Collision-free flag per row of ``qs`` (controllable joint order) in the world described by ``spec``."""
    return Labelling(spec, robot_id, qs, workers).result(progress, helper)
