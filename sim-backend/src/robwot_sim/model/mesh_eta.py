"""The time left of a robot's first load: its concave meshes decomposed side by side, largest first.

Pure bookkeeping (the caller passes the clock's readings): each concave mesh is queued, then started on
a worker, then done. The rate is the worker seconds per triangle of the meshes done; a mesh not done is
expected to take its triangles at that rate, one started already that much less the time it has run.
The time left is the longest such mesh still running, or the work left spread over the workers when
that is longer. It is unknown (None) before any concave mesh is done, and as soon as a running mesh has
outrun its estimate: a mesh's time grows faster than its triangles, so small meshes done early
underestimate a large one; an estimate that would read 0 while that mesh still runs is never given.
"""

from __future__ import annotations

import threading


class MeshEta:
    """What a decomposition has left (module doc); safe to call from the worker threads."""

    def __init__(self, faces: dict[str, int], workers: int) -> None:
        self._faces = dict(faces)
        self._workers = max(1, workers)
        self._started: dict[str, float] = {}
        self._done_faces = 0
        self._done_seconds = 0.0
        self._lock = threading.Lock()

    def start(self, key: str, now: float) -> None:
        """``key`` begins at ``now`` (a key it was not given, a convex mesh, is not counted)."""
        with self._lock:
            if key in self._faces:
                self._started[key] = now

    def done(self, key: str, now: float) -> float | None:
        """Records ``key`` done at ``now`` and returns the time left (s) then, or None when unknown."""
        with self._lock:
            began = self._started.pop(key, now)
            self._done_faces += self._faces.pop(key, 0)
            self._done_seconds += now - began
            return self._left(now)

    def _left(self, now: float) -> float | None:
        if not self._faces:
            return 0.0
        if self._done_faces == 0:
            return None
        rate = self._done_seconds / self._done_faces
        if rate <= 0.0:
            return None
        running = [rate * self._faces[k] - (now - t) for k, t in self._started.items()]
        if any(r <= 0.0 for r in running):
            return None
        queued = [rate * f for k, f in self._faces.items() if k not in self._started]
        return max(max(running, default=0.0), (sum(running) + sum(queued)) / self._workers)
