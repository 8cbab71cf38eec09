"""Merging convex parts down to a cap, cheapest union first, and below it only while merging is cheap.

CoACD cuts a mesh until every piece is nearly convex; a detailed mesh (engraved text, screw holes, fillets)
comes out in hundreds of pieces. Its own merge step then compares every pair of pieces against the mesh,
which is quadratic in the pieces with a costly measure per pair, and on such meshes it takes several
times as long as the cuts themselves (README "The paper's robots"). This merge is greedy over neighbours
only: two parts whose bounding boxes lie within ``NEAR`` of the mesh size of each other are candidates,
their cost is the volume their union's hull adds to theirs (the space a collision check would wrongly call
occupied), and the cheapest pair is merged until at most ``most`` parts are left. Parts that are no
candidate of anyone (islands) are paired with every other part once the candidates run out, so that cap
always holds. Below it, merging goes on down to ``limit`` parts only while the cheapest merge adds less
than ``budget`` times the live parts' total volume: a mesh whose pieces tile a simple shape ends at
``limit``, one whose pieces would only merge into much fatter hulls (a hollow base, a bracket) keeps more.
"""

from __future__ import annotations

import heapq

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: how close (a fraction of the whole mesh's size) two parts' bounding boxes must come to be merge candidates
NEAR = 0.02


def _hull(points: FloatArray) -> tuple[FloatArray, float]:
    """The hull's vertices of ``points`` and its volume (a flat or degenerate set: itself, volume 0)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points, qhull_options="QJ")
    except (QhullError, ValueError):
        return points, 0.0
    return points[hull.vertices], float(hull.volume)


class _Parts:
    """The live parts: hull vertices, volumes, bounding boxes and a version per slot (bumped on merge)."""

    def __init__(self, parts: list[FloatArray]) -> None:
        hulls = [_hull(np.asarray(p, dtype=np.float64)) for p in parts]
        self.points = [h[0] for h in hulls]
        self.volume = np.array([h[1] for h in hulls])
        self.lo = np.array([p.min(axis=0) for p in self.points])
        self.hi = np.array([p.max(axis=0) for p in self.points])
        self.alive = np.ones(len(parts), dtype=bool)
        self.version = np.zeros(len(parts), dtype=np.int64)
        self.gap = NEAR * float(np.ptp(np.vstack(self.points), axis=0).max())

    def near(self, i: int) -> npt.NDArray[np.intp]:
        """The live parts other than ``i`` whose boxes come within the gap of part ``i``'s box."""
        close = np.all((self.lo <= self.hi[i] + self.gap) & (self.lo[i] <= self.hi + self.gap), axis=1)
        close &= self.alive
        close[i] = False
        return np.flatnonzero(close)

    def union(self, i: int, j: int) -> tuple[FloatArray, float]:
        return _hull(np.vstack([self.points[i], self.points[j]]))

    def cost(self, i: int, j: int) -> float:
        """The volume the hull of parts i and j adds to theirs (negative when they overlap)."""
        return self.union(i, j)[1] - float(self.volume[i] + self.volume[j])

    def merge(self, i: int, j: int) -> None:
        """Part i becomes the hull of i and j; j is gone."""
        points, volume = self.union(i, j)
        self.points[i], self.volume[i] = points, volume
        self.lo[i], self.hi[i] = points.min(axis=0), points.max(axis=0)
        self.version[i] += 1
        self.alive[j] = False


def merge_parts(parts: list[FloatArray], limit: int, most: int | None = None,
                budget: float = 0.0) -> list[FloatArray]:
    """Convex parts (their hull vertices) covering every given part (vertex arrays), at most ``most``
    (default ``limit``) of them and at most ``limit`` when merging is cheap: the cheapest candidate pair
    is merged first (module docstring) until at most ``most`` are left, then on down to ``limit`` while
    the cheapest merge adds less than ``budget`` times the sum of the live parts' volumes (islands are
    paired only to meet ``most``). Deterministic: ties go to the lowest indices."""
    most = limit if most is None else max(most, limit)
    if len(parts) <= limit:
        return [np.asarray(p, dtype=np.float64) for p in parts]
    state = _Parts(parts)
    heap: list[tuple[float, int, int, int, int]] = []

    def push(i: int, j: int) -> None:
        a, b = min(i, j), max(i, j)
        heapq.heappush(heap, (state.cost(a, b), a, b, int(state.version[a]), int(state.version[b])))

    for i in range(len(parts)):
        for j in state.near(i):
            if j > i:
                push(i, int(j))
    while (left := int(state.alive.sum())) > limit:
        if not heap:
            if left <= most:
                break  # no candidates left below the cap
            live = np.flatnonzero(state.alive).tolist()  # islands: every live pair becomes a candidate once
            for n, a in enumerate(live):
                for b in live[n + 1:]:
                    push(a, b)
            continue
        cost, i, j, vi, vj = heap[0]
        if not (state.alive[i] and state.alive[j]) or vi != state.version[i] or vj != state.version[j]:
            heapq.heappop(heap)
            continue  # stale: one of the two has merged since
        if left <= most and cost >= budget * float(state.volume[state.alive].sum()):
            break  # below the cap, the cheapest merge is too costly
        heapq.heappop(heap)
        state.merge(i, j)
        for k in state.near(i):
            push(i, int(k))
    return [state.points[k] for k in np.flatnonzero(state.alive)]
