"""A local generation's chunks (``chunk.label_chunk``, the unit of work of cluster runs too) on the
worker pool (``pool.py``).

Work is split in chunks for progress reporting and load balance; the calling process may compute chunks
too (``helper``: its own ``World`` labels them) until a worker answers, which hides the workers' start-up;
then it leaves them every core.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InternalError, SimError
from robwot_sim.workspace.chunk import Chunk, ChunkJob, label_chunk
from robwot_sim.workspace.pool import acquire_pool, answered, ping, release_pool, spec_key, warm_up, warming

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
__all__ = ["Labelling", "chunk_size", "label_samples", "rebuild_error", "spec_key", "warm_up"]

MIN_CHUNK = 500
# Ray pays per task, so chunks are large (README "Running on a Ray cluster" has the measurement); the local
# pool is indifferent to the chunk size within this range.
MAX_CHUNK = 12_000
CHUNKS_PER_WORKER = 16
HELPER_STEP = 250


def chunk_size(n: int, workers: int) -> int:
    return max(MIN_CHUNK, min(MAX_CHUNK, math.ceil(n / (workers * CHUNKS_PER_WORKER))))


class Labelling:
    """The chunks of ``samples`` rows of ``job``. The pool is started and the chunks submitted by a
    background thread, so the caller can compute chunks itself (``result(helper=...)``) in the meantime:
    chunks are submitted from the start to the workers, and the caller claims the first one no worker has
    started, so chunks finish nearly in sample order (a streaming ``sink`` holds few of them); not while
    a warm-up (``pool.warm_up``) is starting the workers. If the pool fails to start, a helping caller
    computes everything itself."""

    def __init__(self, job: ChunkJob, samples: int, workers: int) -> None:
        self.n, self.job, self.workers = samples, job, workers
        size = chunk_size(self.n, workers)
        self.chunks = [(a, min(a + size, self.n)) for a in range(0, self.n, size)]
        self._lock = threading.Lock()
        self._taken: set[int] = set()  # claimed by the caller, or collected from a worker
        self._futures: dict[int, Future[Any]] = {}  # submitted to the pool (not cancelled)
        self._stopped = False
        self._error: BaseException | None = None
        self._up: Future[Any] | None = None  # the pool's first answer
        self.pool = acquire_pool(workers)
        # its workers are up, or a warm-up is starting them: the caller leaves every chunk to them (helping
        # meanwhile, it would build a world of its own on a core they need)
        self._warm = answered(workers) or warming(workers)
        self._released = False
        self._submitter = threading.Thread(target=self._submit_all, name="robwot-labelling-submit",
                                           daemon=True)
        self._submitter.start()

    def _submit_all(self) -> None:
        try:
            self._up = self.pool.submit(ping)  # starts the forkserver and the workers: the slow part
            for i, (a, b) in enumerate(self.chunks):
                with self._lock:
                    if self._stopped:
                        return
                    if i not in self._taken:
                        self._futures[i] = self.pool.submit(label_chunk, self.job, a, b - a)
        except (BrokenProcessPool, RuntimeError) as e:
            self._error = e

    def _claim(self) -> int | None:
        """The first chunk no worker has started, now the caller's (cancelled in the pool if queued)."""
        with self._lock:
            for i in range(len(self.chunks)):
                if i in self._taken:
                    continue
                f = self._futures.get(i)
                if f is None or f.cancel():
                    self._futures.pop(i, None)
                    self._taken.add(i)
                    return i
        return None

    def _pool_up(self) -> bool:
        """Whether a worker has answered: the caller then leaves the chunks to the workers, which have every
        core (a caller helping them on would only take a core from one)."""
        up = self._up
        return self._warm or (up is not None and up.done() and up.exception() is None)

    def _stop(self, broken: bool = False) -> None:
        with self._lock:
            self._stopped = True
            for f in self._futures.values():
                f.cancel()
        if not self._released:
            self._released = True
            release_pool(self.workers, broken)

    def abandon(self) -> None:
        """Stop submitting, cancel what no worker has started and release the pool."""
        self._stop()

    def result(self, progress: Callable[[int, int], None] | None = None,
               helper: Callable[[FloatArray], BoolArray] | None = None,
               sink: Callable[[int, Chunk], None] | None = None) -> list[Chunk]:
        """Wait for every chunk; ``progress(done, total)`` after each. Releases the pool. Returns the
        chunks in sample order, or, with ``sink``, passes each to ``sink(index, chunk)`` as it finishes
        (in any order) and keeps none (returns ``[]``): memory then does not grow with ``samples``.

        ``helper`` (e.g. the calling process's own ``World.collision_free_batch``) labels the rows of the
        chunks that no worker has started, ``HELPER_STEP`` rows per call (short lock holds), until a worker
        has answered (``_pool_up``).
        If the pool breaks (a worker crashed, or workers cannot start, e.g. ``__main__`` read from stdin),
        the helper labels the remaining chunks; without a helper that is an ``InternalError``.
        """
        out: dict[int, Chunk] = {}  # finished chunks, unless sunk
        finished: set[int] = set()
        progress = progress or (lambda _d, _t: None)

        def done(i: int, chunk: Chunk) -> None:
            finished.add(i)
            if sink is None:
                out[i] = chunk
            else:
                sink(i, chunk)

        def steps(qs: FloatArray) -> BoolArray:
            assert helper is not None
            return np.concatenate([helper(qs[s:s + HELPER_STEP]) for s in range(0, len(qs), HELPER_STEP)])

        def own(i: int) -> None:
            a, b = self.chunks[i]
            done(i, self._chunk(label_chunk(self.job, a, b - a, steps)))

        def collect(futures: dict[int, Future[Any]]) -> None:
            for i, f in list(futures.items()):
                if i in finished or not f.done():
                    continue
                done(i, self._chunk(f.result()))
                with self._lock:  # a future holds its result: drop it (taken: never claimed again)
                    self._futures.pop(i, None)
                    self._taken.add(i)

        def count() -> int:
            return sum(self.chunks[i][1] - self.chunks[i][0] for i in finished)

        broken = False
        try:
            try:
                while helper is not None and not self._pool_up() and (i := self._claim()) is not None:
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
        return [] if sink is not None else [out[i] for i in range(len(self.chunks))]

    @staticmethod
    def _chunk(res: Chunk | dict[str, Any]) -> Chunk:
        if isinstance(res, dict):
            raise rebuild_error(res)
        return res


def rebuild_error(res: dict[str, Any]) -> SimError:
    err = res["error"]
    data = dict(err.get("data", {}))
    code = data.pop("code", "E_INTERNAL")
    # the number follows the code (the contract's), as it did in the worker
    return SimError(f"collision worker: {err.get('message', '')}", code=code, **data)


def label_samples(job: ChunkJob, samples: int, workers: int,
                  progress: Callable[[int, int], None] | None = None,
                  helper: Callable[[FloatArray], BoolArray] | None = None) -> list[Chunk]:
    """The chunks of rows ``0 .. samples - 1`` of ``job``, computed by ``workers`` processes."""
    return Labelling(job, samples, workers).result(progress, helper)
