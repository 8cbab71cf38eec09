"""Workspace generation: sample configurations, vectorised FK, parallel collision labelling, alpha shape.

``generate_workspace`` writes ``workspace.csv`` and ``workspace.stl`` into ``out_dir`` and returns the
WorkspaceSummary of ARCHITECTURE.md (Contract 2). Units: metres, radians, seconds; world frame.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

import robwot_sim
from robwot_sim.errors import InvalidParams
from robwot_sim.model.fk import ChainFK
from robwot_sim.twin_layout import POINT_CLOUD, REACHABILITY, SURFACE
from robwot_sim.workspace.chunk import ChunkJob, ChunkSink
from robwot_sim.workspace.io import atomic_write, csv_layout, write_stl
from robwot_sim.workspace.labelling import Labelling, warm_up
from robwot_sim.workspace.reachability import (
    BASE_VOXEL,
    DIRECTIONS,
    MAX_VOXEL,
    MIN_VOXEL,
)

if TYPE_CHECKING:
    from robwot_sim.sim.world import World

# scipy (alpha shape) is imported on first use: worker processes import this package and need only
# the labelling, and they start faster without it.
__all__ = ["ALPHA_MAX_POINTS", "ChainFK", "chain_fk", "generate_workspace", "warm_up"]

# The alpha shape is built from at most this many collision-free points: the first ones in sample order
# (a uniform subsample, the samples being i.i.d.). Every run up to ~10^6 samples uses all of them; a
# 10^7-sample run (cluster) keeps the driver's memory and the triangulation bounded.
ALPHA_MAX_POINTS = 1_000_000

Progress = Callable[[str, int, int], None]


def versions() -> dict[str, str]:
    """Versions of the tools that produced a workspace."""
    from importlib import metadata

    import scipy
    try:
        pybullet = metadata.version("pybullet")
    except metadata.PackageNotFoundError:  # pragma: no cover - pybullet is a dependency
        pybullet = "unknown"
    return {"robwot_sim": robwot_sim.__version__, "pybullet": pybullet, "numpy": np.__version__,
            "scipy": scipy.__version__}


def chain_fk(world: World, robot_id: str) -> ChainFK:
    """Vectorised FK of a loaded robot's end-effector link (its URDF chain and base pose)."""
    model = world.robot_model(robot_id)
    return ChainFK.from_joints(model.joints, model.links, model.ee_link, model.controllable,
                               base_position=model.base_position, base_orientation=model.base_orientation)


def _check(samples: int, seed: int, workers: int | None, alpha: float | str) -> tuple[int, float | str]:
    def is_int(v: object) -> bool:
        return isinstance(v, (int, np.integer)) and not isinstance(v, bool)

    if not is_int(samples) or samples < 1:
        raise InvalidParams("samples must be an integer >= 1", param="samples", expected="integer >= 1",
                            got=samples)
    if not is_int(seed) or seed < 0:
        raise InvalidParams("seed must be an integer >= 0", param="seed", expected="integer >= 0", got=seed)
    n = (os.cpu_count() or 1) if workers is None else workers
    if not is_int(n) or n < 1:
        raise InvalidParams("workers must be an integer >= 1", param="workers", expected="integer >= 1",
                            got=workers)
    if alpha != "auto":
        if isinstance(alpha, bool) or not isinstance(alpha, (int, float)) or not math.isfinite(alpha) \
                or alpha <= 0:
            raise InvalidParams('alpha must be "auto" or a radius in metres > 0', param="alpha",
                                expected='"auto" or number > 0', got=alpha)
        alpha = float(alpha)
    return int(n), alpha


def _reach_voxel(voxel: float | str) -> float | str:
    if voxel == "auto":
        return voxel
    if isinstance(voxel, bool) or not isinstance(voxel, (int, float)) or not MIN_VOXEL <= voxel <= MAX_VOXEL:
        raise InvalidParams(f'reachVoxel must be "auto" or a voxel side within [{MIN_VOXEL}, {MAX_VOXEL}] m',
                            param="reachVoxel", expected=f'"auto" or {MIN_VOXEL}..{MAX_VOXEL}', got=voxel)
    return float(voxel)


def _out_dir(out_dir: str | Path) -> Path:
    if not isinstance(out_dir, (str, Path)) or not str(out_dir):
        raise InvalidParams("outDir must be a folder path", param="outDir", expected="string", got=out_dir)
    out = Path(out_dir).expanduser()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InvalidParams(f"outDir {str(out)!r} cannot be created: {e.strerror}", param="outDir",
                            expected="a writable folder", got=str(out)) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise InvalidParams(f"outDir {str(out)!r} is not writable", param="outDir",
                            expected="a writable folder", got=str(out))
    return out


def _bounds(points: np.ndarray) -> dict[str, list[float] | None]:
    if len(points) == 0:
        return {"min": None, "max": None}
    return {"min": [float(v) for v in points.min(axis=0)], "max": [float(v) for v in points.max(axis=0)]}


def generate_workspace(world: World, robot_id: str, *, samples: int = 80_000, seed: int = 1,
                       workers: int | None = None, alpha: float | str = "auto", out_dir: str | Path,
                       csv_joints: bool = False, reach_voxel: float | str = "auto",
                       cluster: str | None = None, progress: Progress | None = None) -> dict[str, Any]:
    """Sample ``samples`` configurations (seeded), label them in ``workers`` processes, build the alpha
    shape of the collision-free end-effector positions and write ``workspace.csv``/``workspace.stl`` and
    the reachability map ``reachability.csv`` (``reachability.py``; voxel side ``reach_voxel`` m or
    ``"auto"``).

    Both paths run the same chunks (``chunk.label_chunk``). Locally, while the worker pool starts, the
    calling thread computes chunks no worker has started, labelling with ``world`` itself (short calls,
    so other requests on ``world`` are only briefly held).

    With ``cluster`` (a Ray address or ``"auto"``), the chunks run as Ray tasks on that cluster instead
    (``cluster.py``; ``workers`` is then unused) and give the same files.

    Returns the WorkspaceSummary; ``bounds`` are those of the collision-free points (``None`` when there
    is none), ``reachBounds`` the box of every position the end link can reach (``ChainFK.reach_bounds``,
    holding ``bounds``); ``timings`` in seconds: ``sample`` = the reach box, ``collide`` = wall time of
    the chunks (``chunk.py``: sampling, FK, labelling, CSV lines and reachability counts, in parallel),
    ``alpha``, ``write`` (after the alpha shape: a local run's CSV is written during it, by a second
    thread; a cluster run's while the chunks arrive). A ``warning`` key appears when the alpha shape fell
    back to the convex hull or the workspace is flat but not a planar region; ``halfThickness`` (m) when
    it is flat (``flat_shape.py``).
    """
    from robwot_sim.workspace.cluster import cluster_address

    n_workers, alpha_arg = _check(samples, seed, workers, alpha)
    voxel_arg = _reach_voxel(reach_voxel)
    address = cluster_address(cluster)
    report: Progress = progress or (lambda _s, _d, _t: None)
    model = world.robot_model(robot_id)
    out = _out_dir(out_dir)
    spec = world.scene_spec()
    for r in spec.get("robots", []):
        if r.get("id") == robot_id:
            r.pop("positions", None)  # irrelevant to labelling: keeps the workers' cached world valid
    fk = chain_fk(world, robot_id)
    lower, upper = model.limits()
    base_voxel = BASE_VOXEL if voxel_arg == "auto" else float(voxel_arg)
    t_reach = time.perf_counter()
    reach_min, reach_max = fk.reach_bounds(lower, upper, int(seed))
    t_reach = time.perf_counter() - t_reach

    from robwot_sim.workspace.pool import spec_key

    header, row_format = csv_layout(len(model.controllable) if csv_joints else None, model.controllable)
    job = ChunkJob(spec_key(spec), spec, robot_id, fk, np.asarray(lower, dtype=np.float64),
                   np.asarray(upper, dtype=np.float64), int(seed), base_voxel, row_format, csv_joints)
    report("sample", samples, samples)
    report("collide", 0, samples)
    if address is not None:
        from robwot_sim.workspace.cluster import run_chunks

        run = run_chunks(address, job, int(samples), header, out / POINT_CLOUD,
                         lambda done, total: report("collide", done, total), ALPHA_MAX_POINTS)
        alpha_points, free_count, reach, t_collide = run.alpha_points, run.collision_free, run.reach, \
            run.seconds
        lo, hi = run.lo, run.hi
    else:
        # streamed like a cluster run: each chunk's rows are written once the earlier ones are
        t1 = time.perf_counter()
        sink = ChunkSink(base_voxel, ALPHA_MAX_POINTS, lambda _b: None)

        def write(f: BinaryIO) -> None:
            f.write((",".join(header) + "\n").encode())
            sink.write = f.write
            Labelling(job, int(samples), n_workers).result(
                lambda done, total: report("collide", done, total),
                helper=lambda q: world.collision_free_batch(robot_id, q), sink=sink.add)

        atomic_write(out / POINT_CLOUD, write)
        t_collide = time.perf_counter() - t1
        alpha_points, free_count, reach, lo, hi = sink.alpha_points(), sink.free, sink.reach, sink.lo, sink.hi
    t2 = time.perf_counter()
    report("alpha", 0, 1)
    from robwot_sim.workspace.alpha_shape import alpha_shape

    shape = alpha_shape(alpha_points, alpha_arg)
    report("alpha", 1, 1)
    t3 = time.perf_counter()
    report("write", 0, 2)
    report("write", 1, 2)
    bounds: dict[str, list[float] | None] = (
        {"min": None, "max": None} if lo is None or hi is None
        else {"min": [float(v) for v in lo], "max": [float(v) for v in hi]})
    t_sample = t_reach
    write_stl(out / SURFACE, shape.vertices, shape.triangles)
    if voxel_arg == "auto":
        reach = reach.auto()
    reach.write_csv(out / REACHABILITY)
    report("write", 2, 2)
    t4 = time.perf_counter()

    if bounds["min"] is not None and bounds["max"] is not None:  # the box holds every sample, by construction
        reach_min, reach_max = np.minimum(reach_min, bounds["min"]), np.maximum(reach_max, bounds["max"])
    summary: dict[str, Any] = {
        "samples": int(samples), "collisionFree": free_count, "bounds": bounds,
        "reachBounds": {"min": reach_min.tolist(), "max": reach_max.tolist()},
        "alpha": shape.alpha, "method": shape.method, "volume": shape.volume, "seed": int(seed),
        "reachability": {"file": REACHABILITY, "voxel": reach.voxel, "voxels": reach.voxels,
                         "directions": DIRECTIONS, "approachAxis": "z"},
        "timings": {"sample": t_sample, "collide": t_collide, "alpha": t3 - t2, "write": t4 - t3},
        "versions": versions()}
    if shape.warning is not None:
        summary["warning"] = shape.warning
    from robwot_sim.workspace.flat_shape import FlatShape

    if isinstance(shape, FlatShape):
        summary["halfThickness"] = shape.half_thickness
    return summary
