"""Reachability map: a voxel grid over the sampled end-link positions with a reachability index per voxel.

Per voxel (side ``voxel`` m; voxels aligned to the world origin, voxel ``(i, j, k)`` spans
``[i·voxel, (i+1)·voxel)`` on each axis):

- ``samples``: sampled configurations whose end-link origin lies in the voxel;
- ``free``: the collision-free ones among them;
- ``directions``: distinct approach directions reached collision-free — the end link's z axis (the ROS
  tool convention: z is the approach axis) binned to the nearest of ``DIRECTIONS`` = 64 directions of a
  spherical Fibonacci lattice;
- ``index = directions / DIRECTIONS`` in [0, 1]: the share of the orientation sphere from which the voxel is
  reached without collision (the reachability index D of Reuleaux and REACH, as a fraction).

The index is bounded by the sampling: a voxel with ``free`` samples reaches at most ``free`` directions, so
coarse voxels (or more samples) are needed for a meaningful index. ``voxel="auto"`` therefore picks it from
the data: counts are gathered at ``BASE_VOXEL`` (1 cm) and merged into voxels of 1, 2, 4, ... cm until the
voxels with a collision-free sample hold ``AUTO_FREE_PER_VOXEL`` (32) collision-free samples on average
(at most ``MAX_VOXEL``).

Counts add and direction masks OR, so chunks (worker processes, cluster tasks) fold into one map in any
order with the same result: ``ReachabilityMap.add`` per chunk, ``merge`` of maps, ``coarsen`` to a larger
voxel.

File ``reachability.csv``: header ``x,y,z,samples,free,directions,index``, one row per voxel holding at
least one sample, sorted by voxel (x, then y, then z index); ``x,y,z`` is the voxel centre (m, world frame,
``%.6f``), the counts are integers and ``index`` has 6 decimals.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robwot_sim.limits import REACH_VOXEL
from robwot_sim.workspace.io import write_table

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]

DIRECTIONS = 64
BASE_VOXEL = 0.01
MIN_VOXEL, MAX_VOXEL = REACH_VOXEL.minimum, REACH_VOXEL.maximum
AUTO_FREE_PER_VOXEL = 32
CSV_HEADER = ("x", "y", "z", "samples", "free", "directions", "index")
_BITS = 21  # per axis: voxel indices within ±2^20 (±5 km at 5 mm)
_OFFSET = 1 << (_BITS - 1)
_MASK = (1 << _BITS) - 1


def _fibonacci_directions(n: int) -> FloatArray:
    i = np.arange(n, dtype=np.float64) + 0.5
    z = 1.0 - 2.0 * i / n
    r = np.sqrt(1.0 - z * z)
    phi = i * math.pi * (3.0 - math.sqrt(5.0))
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


LATTICE = _fibonacci_directions(DIRECTIONS)


def direction_bins(rotations: FloatArray) -> npt.NDArray[np.uint8]:
    """Bin (0..63) of each end-link z axis, from rotation matrices ``(n, 3, 3)`` (world frame)."""
    z = np.asarray(rotations, dtype=np.float64)[:, :, 2]
    return np.asarray(np.argmax(z @ LATTICE.T, axis=1), dtype=np.uint8)


def _pack(ijk: IntArray) -> IntArray:
    o = ijk + _OFFSET
    return np.asarray((o[:, 0] << (2 * _BITS)) | (o[:, 1] << _BITS) | o[:, 2], dtype=np.int64)


def _unpack(keys: IntArray) -> IntArray:
    return np.stack([(keys >> (2 * _BITS)) & _MASK, (keys >> _BITS) & _MASK, keys & _MASK], axis=1) - _OFFSET


def _popcount(masks: npt.NDArray[np.uint64]) -> IntArray:
    as_bytes = masks.astype("<u8").view(np.uint8).reshape(-1, 8)
    return np.asarray(np.unpackbits(as_bytes, axis=1).sum(axis=1), dtype=np.int64)


class ReachabilityMap:
    """Sparse voxel counts; see the module docstring. ``voxel`` in metres."""

    def __init__(self, voxel: float = BASE_VOXEL) -> None:
        if not (isinstance(voxel, (int, float)) and math.isfinite(voxel) and MIN_VOXEL <= voxel <= MAX_VOXEL):
            raise ValueError(f"voxel must be within [{MIN_VOXEL}, {MAX_VOXEL}] m, got {voxel!r}")
        self.voxel = float(voxel)
        self._parts: list[tuple[IntArray, IntArray, IntArray, npt.NDArray[np.uint64]]] = []
        self._rows = 0  # rows in _parts, compacted when twice the last compacted size
        self._compacted = 0

    def add(self, positions: FloatArray, collision_free: BoolArray, bins: npt.NDArray[np.uint8]) -> None:
        """Counts of one chunk: positions ``(n, 3)`` (m), flags ``(n,)``, direction bins ``(n,)``."""
        p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        if len(p) == 0:
            return
        free = np.asarray(collision_free, dtype=bool).reshape(-1)
        keys = _pack(np.floor(p / self.voxel).astype(np.int64))
        bits = np.where(free, np.left_shift(np.uint64(1), np.asarray(bins, dtype=np.uint64)), np.uint64(0))
        self._fold(keys, np.ones(len(p), dtype=np.int64), free.astype(np.int64), bits)

    def merge(self, other: ReachabilityMap) -> None:
        if other.voxel != self.voxel:
            raise ValueError(f"cannot merge maps of voxel {other.voxel} m into {self.voxel} m")
        self._fold(*other._table())

    def _fold(self, keys: IntArray, samples: IntArray, free: IntArray, masks: npt.NDArray[np.uint64]) -> None:
        self._parts.append(_reduce(keys, samples, free, masks))
        self._rows += len(self._parts[-1][0])
        if self._rows > max(2 * self._compacted, 1 << 16):
            self._table()

    def _table(self) -> tuple[IntArray, IntArray, IntArray, npt.NDArray[np.uint64]]:
        if len(self._parts) != 1:
            if not self._parts:
                empty = np.zeros(0, dtype=np.int64)
                return empty, empty, empty, np.zeros(0, dtype=np.uint64)
            self._parts = [_reduce(*(np.concatenate(c) for c in zip(*self._parts, strict=True)))]
        self._rows = self._compacted = len(self._parts[0][0])
        return self._parts[0]

    def coarsen(self, factor: int) -> ReachabilityMap:
        """The same counts in voxels ``factor`` times larger (``factor`` >= 1, integer)."""
        keys, samples, free, masks = self._table()
        out = ReachabilityMap(self.voxel * factor)
        coarse = _pack(np.floor_divide(_unpack(keys), factor))
        out._fold(coarse, samples, free, masks)
        return out

    def auto(self, target: int = AUTO_FREE_PER_VOXEL) -> ReachabilityMap:
        """The smallest coarsening by 2^k whose voxels with a collision-free sample hold ``target``
        collision-free samples on average (or the largest within ``MAX_VOXEL``)."""
        factor, best = 1, self
        while True:
            _, _, free, _ = best._table()
            reached = free[free > 0]
            if reached.size == 0 or reached.mean() >= target or self.voxel * factor * 2 > MAX_VOXEL:
                return best
            factor *= 2
            best = self.coarsen(factor)

    @property
    def voxels(self) -> int:
        return len(self._table()[0])

    def columns(self) -> tuple[FloatArray, IntArray, IntArray, IntArray, FloatArray]:
        """Voxel centres ``(m, 3)``, samples, free, directions, index — sorted by voxel."""
        keys, samples, free, masks = self._table()
        centres = (_unpack(keys).astype(np.float64) + 0.5) * self.voxel
        directions = _popcount(masks)
        return centres, samples, free, directions, directions / DIRECTIONS

    def write_csv(self, path: str | Path) -> None:
        centres, samples, free, directions, index = self.columns()
        write_table(path, CSV_HEADER, "%.6f,%.6f,%.6f,%d,%d,%d,%.6f",
                    np.column_stack([centres, samples, free, directions, index]))


def _reduce(keys: IntArray, samples: IntArray, free: IntArray,
            masks: npt.NDArray[np.uint64]) -> tuple[IntArray, IntArray, IntArray, npt.NDArray[np.uint64]]:
    if len(keys) == 0:
        return keys, samples, free, masks
    order = np.argsort(keys, kind="stable")
    k = keys[order]
    starts = np.flatnonzero(np.concatenate(([True], k[1:] != k[:-1])))
    return (k[starts], np.add.reduceat(samples[order], starts), np.add.reduceat(free[order], starts),
            np.bitwise_or.reduceat(masks[order], starts))
