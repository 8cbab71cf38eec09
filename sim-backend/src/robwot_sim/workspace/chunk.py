"""One chunk of a workspace generation, computed where it runs: rows ``start .. start + count - 1`` of the
seeded samples (``sampling.py``), their end-link poses (``fk.py``), their collision labels (in the
process's cached world, ``pool.worker_label``), their ``workspace.csv`` lines and their reachability counts.

This is the unit of work of every generation: a task of the local process pool (``labelling.py``, also
run by the calling process itself while it would wait) and a Ray task of a cluster run (``cluster.py``).
The rows and their labels depend only on ``(seed, row)`` (a row's label is the same whichever path labels
it and whatever was checked before it: ``client.Recheck``), so any split into chunks among
processes gives the same files, the chunks the calling process labels while the workers start, without
the outer bounds' kernels (``labelling.py``), included. ``ChunkSink`` folds finished chunks, in chunk
order, into what a generation keeps (the same code for both).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.model.couplings import Followers
from robwot_sim.model.fk import ChainFK, end_frames
from robwot_sim.model.meshcheck import FileStamp
from robwot_sim.workspace.io import csv_table, format_rows
from robwot_sim.workspace.reachability import ReachabilityMap, direction_bins
from robwot_sim.workspace.sampling import sample_configurations

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
UInt8Array = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class ChunkJob:
    """What every chunk of one generation shares (sent once to a cluster, ``ray.put``)."""

    key: str  # pool.spec_key(spec): identifies the worker's cached world
    spec: dict[str, Any]  # the scene document (World.scene_spec), files at the same paths on the workers
    robot_id: str
    fk: ChainFK
    lower: FloatArray
    upper: FloatArray
    seed: int
    voxel: float  # reachability voxel of the partial maps (m)
    row_format: str  # workspace.csv row format (io.csv_layout)
    joints: bool  # joint columns in workspace.csv
    #: a draw that drives a follower past its limit is not a configuration of the robot: left out
    followers: Followers | None = None
    #: mesh files the backend's process checked (``meshcheck.checked_meshes``), taken as checked by a local
    #: pool's workers (never sent to a cluster: a stamp names a file of this machine)
    checked_meshes: frozenset[FileStamp] = frozenset()


@dataclass(frozen=True)
class Chunk:
    """A finished chunk: its CSV lines, its collision-free end-link positions and reachability counts."""

    start: int
    count: int
    csv: bytes
    free_points: FloatArray
    reach: ReachabilityMap
    flags: BoolArray  # collision-free flag per row


def end_link(fk: ChainFK, qs: FloatArray, block: int = 100_000) -> tuple[FloatArray, UInt8Array]:
    """End-link positions ``(n, 3)`` and approach-direction bins ``(n,)`` (in blocks to bound memory). Every
    process computes them alike (``fk`` in numpy), whichever computes a chunk: a pool worker, the calling
    process or a Ray worker, so that any split gives the same files and summary."""
    positions = np.empty((len(qs), 3))
    bins = np.empty(len(qs), dtype=np.uint8)
    for a in range(0, len(qs), block):
        p, r = end_frames(fk, qs[a:a + block])
        positions[a:a + block], bins[a:a + block] = p, direction_bins(r)
    return positions, bins


def label_chunk(job: ChunkJob, start: int, count: int,
                label: Callable[[FloatArray], BoolArray] | None = None) -> Chunk | dict[str, Any]:
    """Compute one chunk (see the module docstring). A ``SimError`` while labelling comes back as the
    error dict of ``pool.worker_label`` (rebuilt by the caller with ``labelling.rebuild_error``).
    ``label`` replaces the process's cached world (the calling process labels with its own ``World``)."""
    from robwot_sim.workspace.pool import worker_label

    qs = sample_configurations(job.lower, job.upper, count, job.seed, start)
    if job.followers is not None and len(job.followers):
        qs = qs[job.followers.within(qs)]
    positions, bins = end_link(job.fk, qs)
    flags = (worker_label(job.key, job.spec, job.robot_id, qs, job.checked_meshes) if label is None
             else label(qs))
    if isinstance(flags, dict):
        return flags
    free = np.asarray(flags, dtype=bool)
    reach = ReachabilityMap(job.voxel)
    reach.add(positions, free, bins)
    csv = format_rows(job.row_format, csv_table(positions, free, qs if job.joints else None))
    return Chunk(start, count, csv, np.ascontiguousarray(positions[free]), reach, free)


@dataclass
class ChunkSink:
    """What a generation keeps of its chunks, folded in chunk order (``add`` in any order; a chunk is
    folded once every earlier one is): the CSV lines (passed to ``write``), the reachability counts, the
    collision-free count and bounds, and the first ``alpha_max_points`` collision-free points (in sample
    order) for the alpha shape. Memory: the chunks that wait for an earlier one, and those points."""

    voxel: float
    alpha_max_points: int
    write: Callable[[bytes], Any]
    reach: ReachabilityMap = field(init=False)
    free: int = 0
    lo: FloatArray | None = None
    hi: FloatArray | None = None
    folded: int = 0  # chunks folded so far
    _kept: list[FloatArray] = field(default_factory=list)
    _kept_count: int = 0
    _waiting: dict[int, Chunk] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.reach = ReachabilityMap(self.voxel)

    def add(self, index: int, chunk: Chunk) -> None:
        """Chunk number ``index`` (0, 1, ... in sample order) is finished."""
        self._waiting[index] = chunk
        while self.folded in self._waiting:
            self._fold(self._waiting.pop(self.folded))
            self.folded += 1

    def _fold(self, c: Chunk) -> None:
        self.write(c.csv)
        self.reach.merge(c.reach)
        n = len(c.free_points)
        self.free += n
        if n:
            lo, hi = c.free_points.min(axis=0), c.free_points.max(axis=0)
            self.lo = lo if self.lo is None else np.minimum(self.lo, lo)
            self.hi = hi if self.hi is None else np.maximum(self.hi, hi)
            room = self.alpha_max_points - self._kept_count
            if room > 0:
                self._kept.append(c.free_points[:room])
                self._kept_count += min(room, n)

    def alpha_points(self) -> FloatArray:
        return np.concatenate(self._kept) if self._kept else np.zeros((0, 3))
