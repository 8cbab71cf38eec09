"""No process of the backend's outlives it: its forkserver and collision workers end with it, however it
ends (here SIGKILL, which runs no clean-up at all)."""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import time
from pathlib import Path

import pytest
from rpc_backend import BackendProcess

MODELS = Path(__file__).parent / "models"

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def _stat(pid: int) -> tuple[int, str] | None:
    """(parent pid, start time in clock ticks) of a live process, or None once it is gone (or a zombie)."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()  # after "pid (comm) "
    if fields[0] == "Z":
        return None
    return int(fields[1]), fields[19]


def descendants(root: int) -> dict[int, str]:
    """Every live process below ``root``, by pid, with its start time (a reused pid is another process)."""
    parents: dict[int, list[tuple[int, str]]] = {}
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and (st := _stat(int(entry.name))) is not None:
            parents.setdefault(st[0], []).append((int(entry.name), st[1]))
    found: dict[int, str] = {}
    todo = [root]
    while todo:
        for pid, start in parents.get(todo.pop(), []):
            found[pid] = start
            todo.append(pid)
    return found


def survivors(procs: dict[int, str]) -> list[int]:
    return [pid for pid, start in procs.items() if (st := _stat(pid)) is not None and st[1] == start]


def test_a_killed_backend_leaves_no_worker_process(tmp_path: Path) -> None:
    """A backend that started its collision pool (a small generation on 2 workers) is SIGKILLed: its
    forkserver and both workers are gone within 5 s (they used to run on, ~340 MB each)."""
    proc = BackendProcess()
    try:
        client = proc.client()
        client.call("robot.load", {"urdf": str(MODELS / "planar2.urdf"), "id": "arm"})
        client.call("workspace.generate", {"robot": "arm", "samples": 20_000, "workers": 2,
                                           "outDir": str(tmp_path / "ws")}, timeout=120)
        kids = descendants(proc.proc.pid)
        assert len(kids) >= 3, f"expected a forkserver and 2 workers below the backend, found {kids}"
        client.close()
    finally:
        proc.stop(signal.SIGKILL)
    deadline = time.monotonic() + 5.0
    while survivors(kids) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = survivors(kids)
    try:
        assert not left, f"{len(left)} of {len(kids)} descendants outlived the killed backend: {left}"
    finally:
        for pid in left:  # do not leave them to the next test either
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)


def test_warm_workers_start_with_the_server_and_end_with_it() -> None:
    """``serve --warm-workers 2`` starts the forkserver and two workers while the server starts (no request
    asked for them); a SIGKILL of the backend still takes them all along."""
    proc = BackendProcess("--warm-workers", "2")
    try:
        proc.client().close()  # the server answers
        deadline = time.monotonic() + 120.0
        while len(kids := descendants(proc.proc.pid)) < 3 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert len(kids) >= 3, f"expected a forkserver and 2 workers below the backend, found {kids}"
    finally:
        proc.stop(signal.SIGKILL)
    deadline = time.monotonic() + 5.0
    while survivors(kids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not survivors(kids)


@pytest.mark.parametrize("value", ["-1", "257", "two"])
def test_a_bad_warm_workers_count_is_refused(value: str) -> None:
    import subprocess

    run = subprocess.run([sys.executable, "-m", "robwot_sim", "serve", "--warm-workers", value],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 2 and "--warm-workers" in run.stderr
