"""The one thread that owns a World, and how long operations share it (stdlib only: no PyBullet here).

Every PyBullet call of the server runs on one thread (`WorldThread`, an executor with one worker); the
asyncio loop only awaits it, so it never blocks on the world and never takes a lock a long operation
holds. Jobs come in three kinds:

- ``SHORT``: a read, or a step of a motion (another robot's joints set, checked, its pose read). It may
  also run *inside* a long job, at one of its checkpoints, so it waits at most one checkpoint interval.
- ``LONG``: a search (plan, IK restarts, detour, path check). Its loops call `checkpoint()` where the
  world is consistent, which runs the queued short jobs inline and raises `Cancelled` once the job's
  caller gave up (``robot.stop``, shutdown), or `PlanBudget` once a job given a ``budget`` has run that
  many seconds (a plan never holds the thread without end). While they run, every robot the long job moves
  (`holding`) is put back at its true state and returned to the search's state afterwards: short jobs
  see the world exactly as if the long job were not running.
- ``PLAIN``: anything else (loading a body, editing the scene, removing a robot): runs alone, in order.

A short job never runs inline when it writes a robot that a running long job holds (its state is the
one the search restores at its end), nor after a queued job of the same robot that could not (the
order of one robot's jobs is kept); it then waits for its turn in the queue.

A long job's world may change at its checkpoints (other robots move): a motion stamps the world before
planning, so any such change makes its run-time guard check every step again (`motion_runner.py`), and
a path check measures its distances again after a checkpoint that ran jobs (`pathcheck.first_contact`).
"""

from __future__ import annotations

import contextlib
import enum
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Generic, TypeVar

from robwot_sim.errors import PlanBudget

T = TypeVar("T")

#: puts a held robot back at its true state; returns the function that restores the search's state
Park = Callable[[], Callable[[], None]]


class Cancelled(Exception):
    """A long world job stopped at a checkpoint because its caller no longer wants its result."""


class Kind(enum.Enum):
    SHORT = "short"
    LONG = "long"
    PLAIN = "plain"


class Job(Generic[T]):
    """One unit of world work, run once: from the queue, or inline at a long job's checkpoint."""

    def __init__(self, fn: Callable[[], T], kind: Kind, robot: str | None, writes: bool,
                 cancel: threading.Event | None = None, budget: float | None = None) -> None:
        self.fn, self.kind, self.robot, self.writes = fn, kind, robot, writes
        self.future: Future[T] = Future()
        self.cancel = cancel or threading.Event()  # a long job: stop at the next checkpoint
        self.claimed = False  # guarded by WorldThread._lock
        self.budget = budget  # a long job: seconds from its start to the checkpoint that refuses it
        self.deadline: float | None = None

    def run(self) -> None:
        if not self.future.set_running_or_notify_cancel():
            return
        if self.budget is not None:
            self.deadline = time.monotonic() + self.budget
        try:
            if self.kind is Kind.LONG and self.cancel.is_set():
                raise Cancelled()
            result = self.fn()
        except BaseException as exc:  # handed to whoever awaits the job
            self.future.set_exception(exc)
        else:
            self.future.set_result(result)


_local = threading.local()  # on the world thread: `owner`, the WorldThread


class WorldThread:
    """An executor with one worker thread owning the world (module docstring)."""

    def __init__(self, name: str = "robwot-world") -> None:
        self._executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix=name,
                                            initializer=self._bind)
        self._lock = threading.Lock()
        self._short: list[Job[Any]] = []  # short jobs not yet claimed, in submission order
        self._current: Job[Any] | None = None  # the job the thread is running (not an inline one)
        self._held: list[tuple[str, Park]] = []  # robots the current long job moves, outermost first
        self._inline = False  # a short job is running inside a checkpoint
        self._closing = False  # shutdown: queued jobs are cancelled instead of run
        self.ident: int | None = None

    def _bind(self) -> None:
        _local.owner = self
        self.ident = threading.get_ident()

    def submit(self, fn: Callable[[], T], kind: Kind = Kind.PLAIN, *, robot: str | None = None,
               writes: bool = False, cancel: threading.Event | None = None,
               budget: float | None = None) -> Job[T]:
        """Queue ``fn`` on the world thread; ``robot`` (with ``writes`` when it sets that robot's state)
        is what a short job touches; a long job raises `Cancelled` at its start or next checkpoint once
        ``cancel`` (or ``job.cancel``) is set, and `PlanBudget` at the first checkpoint ``budget`` seconds
        after it started. Raises RuntimeError once the thread is shut down."""
        job: Job[T] = Job(fn, kind, robot, writes, cancel, budget)
        if kind is Kind.SHORT:
            with self._lock:
                self._short.append(job)
        self._executor.submit(self._run_queued, job)
        return job

    def call(self, fn: Callable[[], T], kind: Kind = Kind.PLAIN, *, robot: str | None = None,
             writes: bool = False) -> T:
        """Run ``fn`` on the world thread and wait for it (from another thread: never the world's)."""
        if threading.get_ident() == self.ident:
            raise RuntimeError("WorldThread.call from the world thread itself would wait forever")
        return self.submit(fn, kind, robot=robot, writes=writes).future.result()

    def _run_queued(self, job: Job[Any]) -> None:
        with self._lock:
            if job.claimed:
                return
            job.claimed = True
            if job.kind is Kind.SHORT:  # the list holds unclaimed jobs only (at its head, mostly)
                self._short.remove(job)
        if self._closing:
            job.future.cancel()
            return
        self._current = job
        try:
            job.run()
        finally:
            self._current = None

    def checkpoint(self) -> bool:
        """See the module function `checkpoint`."""
        job = self._current
        if job is None or job.kind is not Kind.LONG or self._inline:
            return False
        if job.cancel.is_set():
            raise Cancelled()
        if job.deadline is not None and time.monotonic() > job.deadline:
            assert job.budget is not None
            raise PlanBudget(job.budget)
        if not self._short or self._closing:  # unlocked peek: a job queued just now waits for the next one
            return False
        with self._lock:
            held = {robot for robot, _ in self._held}
            blocked: set[str | None] = set()
            picked: list[Job[Any]] = []
            waiting: list[Job[Any]] = []
            for short in self._short:
                if short.claimed:
                    continue
                if short.robot in blocked or None in blocked or (short.writes and short.robot in held):
                    blocked.add(short.robot)
                    waiting.append(short)
                    continue
                short.claimed = True
                picked.append(short)
            self._short = waiting
        if not picked:
            return False
        restore = [park() for _, park in reversed(self._held)]  # innermost first
        self._inline = True
        try:
            for short in picked:
                short.run()
        finally:
            self._inline = False
            for back in reversed(restore):
                back()
        return True

    @contextlib.contextmanager
    def holding(self, robot: str, park: Park) -> Iterator[None]:
        """See the module function `holding`."""
        self._held.append((robot, park))
        try:
            yield
        finally:
            self._held.pop()

    def shutdown(self) -> None:
        """Cancel what has not started, stop the running long job at its next checkpoint, and wait until
        the thread has ended (blocking: call it from a helper thread, not the loop)."""
        with self._lock:
            self._closing = True
        current = self._current
        if current is not None:
            current.cancel.set()
        self._executor.shutdown(wait=True)


def _owner() -> WorldThread | None:
    owner: WorldThread | None = getattr(_local, "owner", None)
    return owner


def checkpoint() -> bool:
    """Called by long world operations where the world is consistent but for the robots they hold (see
    `holding`): runs the short jobs queued meanwhile, raises `Cancelled` when the job was given up and
    `PlanBudget` when it has run out of its budget.
    True when jobs ran (other robots may have moved). Off the world thread (tests, worker processes,
    a World without a WorldThread) it does nothing."""
    owner = _owner()
    return False if owner is None else owner.checkpoint()


@contextlib.contextmanager
def holding(robot: str, park: Park) -> Iterator[None]:
    """Within this block the current job moves ``robot`` away from its true state: a checkpoint calls
    ``park()`` (the robot back at its true state, returning how to restore the search's state) around
    the short jobs it runs. Off the world thread it does nothing."""
    owner = _owner()
    if owner is None:
        yield
        return
    with owner.holding(robot, park):
        yield
