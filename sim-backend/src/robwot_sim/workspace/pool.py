"""The worker process pool for collision labelling, and what runs inside a worker.

PyBullet clients cannot be shared across ``fork``, so workers come from a ``forkserver`` (a clean
process, started once, that has already imported numpy, pybullet and the simulation core): forking a
worker from it costs milliseconds instead of a fresh interpreter's import time. Pools (one per worker
count) stay alive between calls; each worker rebuilds its world from the main world's ``scene_spec()``
(obstacles and every robot, with base poses and joint positions) and keeps it while the spec and its
files are unchanged, so a second generation in the same backend skips the rebuild.

No worker outlives the backend, however the backend ends (SIGKILL included, which runs no clean-up).
The forkserver cannot see it: every process it forks holds the write end of its "alive" pipe, so it
exits only once the backend *and* all workers are gone, and idle workers wait forever on a call queue
whose write end they hold themselves. So each worker watches the backend itself (``_worker_start``): a
thread blocked on a pidfd of the backend (polling its pid where pidfds are missing) ends the worker when
the backend exits; the worker also asks the kernel for SIGKILL when its parent, the single-threaded
forkserver, dies. The forkserver then sees end of file on its pipe and exits too.
"""

from __future__ import annotations

import atexit
import ctypes
import ctypes.util
import hashlib
import json
import multiprocessing
import os
import select
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING, Any

from robwot_sim.errors import SimError

if TYPE_CHECKING:  # numpy is the forkserver's to import: the backend starts it before importing numpy
    from robwot_sim.model.meshcheck import FileStamp
    from robwot_sim.sim.types import FloatArray

_PRELOAD = ["robwot_sim.workspace.pool", "robwot_sim.sim.world", "robwot_sim.workspace.preload"]

_pool_lock = threading.Lock()
_pools: dict[int, ProcessPoolExecutor] = {}  # by worker count
_active: dict[int, int] = {}  # running labellings per pool
_answered: set[int] = set()  # pools (by worker count) whose every worker has answered a warm-up
_warming: dict[int, int] = {}  # per pool (by worker count): the warm-ups starting it now

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


def worker_label(key: str, spec: dict[str, Any], robot_id: str, qs: FloatArray,
                 checked_meshes: frozenset[FileStamp] = frozenset()) -> Any:
    """Runs in a worker: label ``qs`` in the cached world (built from ``spec`` when the key changed, taking
    ``checked_meshes`` as checked: the backend's process parsed them, ``meshcheck.vouch``).

    Returns the flag array, or an error dict (``SimError`` subclasses do not all survive pickling).
    """
    global _worker_world
    try:
        if _worker_world is None or _worker_world[0] != key:
            from robwot_sim.model.meshcheck import vouch
            from robwot_sim.sim.world import World

            vouch(checked_meshes)
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
        return _worker_world[1].collision_free_batch(robot_id, qs)
    except SimError as e:
        return {"error": e.to_json(), "type": type(e).__name__}


def ping() -> int:
    return os.getpid()


#: prctl option: the signal the kernel sends when the parent (thread) of the calling process exits
PR_SET_PDEATHSIG = 1
#: seconds between checks that the backend lives, where pidfds are missing
OWNER_POLL = 0.5


def _worker_start(owner: int) -> None:
    """Pool initializer, in each worker: end this worker when ``owner`` (the backend) exits or the
    forkserver (its parent) dies, whatever ends them (module docstring)."""
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(ctypes.util.find_library("c"), use_errno=True)
        libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        if os.getppid() != parent:  # the forkserver died before prctl took effect
            os._exit(1)
    try:
        fd = os.pidfd_open(owner)
    except ProcessLookupError:  # the backend is already gone
        os._exit(1)
    except (AttributeError, OSError):  # no pidfd (not Linux, or an old kernel): poll the pid
        fd = -1

    def watch() -> None:
        if fd >= 0:
            select.select([fd], [], [])  # readable once the process has exited
        else:
            while _alive(owner):
                time.sleep(OWNER_POLL)
        os._exit(1)

    threading.Thread(target=watch, name="robwot-owner-watch", daemon=True).start()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def acquire_pool(workers: int) -> ProcessPoolExecutor:
    """The pool of ``workers`` processes (started on first use). Idle pools of other sizes are stopped;
    busy ones are left to finish. Pair with ``release_pool``."""
    with _pool_lock:
        for size in [k for k in _pools if k != workers and _active.get(k, 0) == 0]:
            _pools.pop(size).shutdown(wait=False, cancel_futures=True)
            _answered.discard(size)
        pool = _pools.get(workers)
        if pool is None:
            ctx = multiprocessing.get_context("forkserver")
            ctx.set_forkserver_preload(_PRELOAD)
            pool = _pools[workers] = ProcessPoolExecutor(max_workers=workers, mp_context=ctx,
                                                         initializer=_worker_start, initargs=(os.getpid(),))
        _active[workers] = _active.get(workers, 0) + 1
        return pool


def release_pool(workers: int, broken: bool = False) -> None:
    with _pool_lock:
        _active[workers] = max(0, _active.get(workers, 0) - 1)
        if broken and workers in _pools:
            _pools.pop(workers).shutdown(wait=False, cancel_futures=True)
            _answered.discard(workers)


def answered(workers: int) -> bool:
    """Whether the pool of ``workers`` processes is running and each of them answered a warm-up."""
    with _pool_lock:
        return workers in _answered and workers in _pools


def warming(workers: int) -> bool:
    """Whether a warm-up (``warm_up``) is starting the pool of ``workers`` processes now."""
    with _pool_lock:
        return _warming.get(workers, 0) > 0


def shutdown_pool() -> None:
    """Stop every worker process (also registered with ``atexit``)."""
    with _pool_lock:
        pools = list(_pools.values())
        _pools.clear()
        _answered.clear()  # a pool started again has to answer again
    for pool in pools:
        pool.shutdown(wait=True, cancel_futures=True)


atexit.register(shutdown_pool)


def warm_up(workers: int | None = None) -> threading.Thread:
    """Start the forkserver and ``workers`` (default: cores) worker processes in a background thread,
    e.g. when the backend starts (RPC ``workspace.warmUp``), so the first generation does not pay for
    it. Returns the thread."""
    n = workers or os.cpu_count() or 1

    def run() -> None:
        pool = acquire_pool(n)
        try:
            futures = [pool.submit(ping) for _ in range(n)]
            wait(futures)
            if all(f.exception() is None for f in futures):
                with _pool_lock:
                    if _pools.get(n) is pool:
                        _answered.add(n)
        except (BrokenProcessPool, RuntimeError):
            pass  # a later generation reports the problem
        finally:
            with _pool_lock:
                _warming[n] -= 1
            release_pool(n)

    with _pool_lock:  # counted before the thread runs: a generation asking at once sees it
        _warming[n] = _warming.get(n, 0) + 1
    thread = threading.Thread(target=run, name="robwot-workspace-warm-up", daemon=True)
    thread.start()
    return thread
