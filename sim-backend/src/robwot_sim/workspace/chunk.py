"""One chunk of a workspace generation, computed where it runs: rows ``start .. start + count - 1`` of the
seeded samples (``sampling.py``), their end-link poses (``fk.py``), their collision labels (in the
process's cached world, ``pool.worker_label``), their ``workspace.csv`` lines and their reachability counts.

This is the unit of work of a cluster run (``cluster.py``, one Ray task per chunk). The rows depend only on
``(seed, row)``, so any split into chunks gives the same files as a local run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.workspace.fk import ChainFK
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


@dataclass(frozen=True)
class Chunk:
    """A finished chunk: its CSV lines, its collision-free end-link positions and reachability counts."""

    start: int
    count: int
    csv: bytes
    free_points: FloatArray
    reach: ReachabilityMap


def end_link(fk: ChainFK, qs: FloatArray, block: int = 100_000) -> tuple[FloatArray, UInt8Array]:
    """End-link positions ``(n, 3)`` and approach-direction bins ``(n,)`` (in blocks to bound memory)."""
    positions = np.empty((len(qs), 3))
    bins = np.empty(len(qs), dtype=np.uint8)
    for a in range(0, len(qs), block):
        p, r = fk.poses(qs[a:a + block])
        positions[a:a + block], bins[a:a + block] = p, direction_bins(r)
    return positions, bins


def label_chunk(job: ChunkJob, start: int, count: int) -> Chunk | dict[str, Any]:
    """Compute one chunk (see the module docstring). A ``SimError`` while labelling comes back as the
    error dict of ``pool.worker_label`` (rebuilt by the caller with ``labelling.rebuild_error``)."""
    from robwot_sim.workspace.pool import worker_label

    qs = sample_configurations(job.lower, job.upper, count, job.seed, start)
    positions, bins = end_link(job.fk, qs)
    flags = worker_label(job.key, job.spec, job.robot_id, qs)
    if isinstance(flags, dict):
        return flags
    free = np.asarray(flags, dtype=bool)
    reach = ReachabilityMap(job.voxel)
    reach.add(positions, free, bins)
    csv = format_rows(job.row_format, csv_table(positions, free, qs if job.joints else None))
    return Chunk(start, count, csv, np.ascontiguousarray(positions[free]), reach)
