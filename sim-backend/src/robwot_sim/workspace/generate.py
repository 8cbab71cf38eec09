"""``generate_workspace`` in named steps: check the request, prepare the job (scene, FK, reach box),
label the samples (locally or on a cluster), build the alpha shape and write the files, summarise.

Writes ``workspace.csv``, ``workspace.stl`` and ``reachability.csv`` into ``out_dir`` and returns the
WorkspaceSummary of ARCHITECTURE.md (Contract 2). Units: metres, radians, seconds; world frame.
"""

from __future__ import annotations

import importlib
import math
import os
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

import robwot_sim
from robwot_sim.errors import InvalidParams
from robwot_sim.model.fk import ChainFK
from robwot_sim.model.meshcheck import checked_meshes
from robwot_sim.twin_layout import POINT_CLOUD, REACHABILITY, SURFACE
from robwot_sim.wholefile import atomic_write
from robwot_sim.workspace.chunk import ChunkJob, ChunkSink
from robwot_sim.workspace.io import csv_layout, write_stl
from robwot_sim.workspace.labelling import Labelling
from robwot_sim.workspace.reachability import (
    BASE_VOXEL,
    DIRECTIONS,
    MAX_VOXEL,
    MIN_VOXEL,
    ReachabilityMap,
)

if TYPE_CHECKING:
    from robwot_sim.sim.world import World
    from robwot_sim.workspace.alpha_shape import AlphaShape
    from robwot_sim.workspace.flat_shape import FlatShape

    Shape = AlphaShape | FlatShape

# The alpha shape is built from at most this many collision-free points: the first ones in sample order
# (a uniform subsample, the samples being i.i.d.). Every run up to ~10^6 samples uses all of them; a
# 10^7-sample run (cluster) keeps the driver's memory and the triangulation bounded.
ALPHA_MAX_POINTS = 1_000_000

Progress = Callable[[str, int, int], None]


def versions() -> dict[str, str]:
    """Versions of the tools that produced a workspace."""
    import scipy

    from robwot_sim.sim.client import pybullet_version
    return {"robwot_sim": robwot_sim.__version__, "pybullet": pybullet_version(), "numpy": np.__version__,
            "scipy": scipy.__version__}


def chain_fk(world: World, robot_id: str) -> ChainFK:
    """Vectorised FK of a loaded robot's end-effector link (its URDF chain and base pose)."""
    model = world.robot_model(robot_id)
    return ChainFK.from_joints(model.joints, model.links, model.ee_link, model.controllable, model.couplings,
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


@dataclass(frozen=True)
class _Request:
    """A checked ``workspace.generate`` request."""

    robot_id: str
    samples: int
    seed: int
    workers: int
    alpha: float | str
    voxel: float | str
    address: str | None  # the Ray cluster's, or None: labelled locally
    out_dir: str | Path  # checked (and created) once the robot is known


@dataclass(frozen=True)
class _Prepared:
    """What the labelling needs: the output folder, the job every chunk runs, the CSV header, the reach
    box."""

    out: Path
    job: ChunkJob
    header: list[str]
    reach_min: np.ndarray
    reach_max: np.ndarray
    reach_seconds: float


@dataclass(frozen=True)
class _Labelled:
    """What the labelling leaves: the points for the alpha shape, the collision-free count and box, the
    reachability counts, its wall time."""

    alpha_points: np.ndarray
    free: int
    lo: np.ndarray | None
    hi: np.ndarray | None
    reach: ReachabilityMap
    seconds: float


def _request(robot_id: str, samples: int, seed: int, workers: int | None, alpha: float | str,
             reach_voxel: float | str, cluster: str | None, out_dir: str | Path) -> _Request:
    from robwot_sim.workspace.cluster import cluster_address

    n_workers, alpha_arg = _check(samples, seed, workers, alpha)
    voxel_arg = _reach_voxel(reach_voxel)
    address = cluster_address(cluster)
    return _Request(robot_id, int(samples), int(seed), n_workers, alpha_arg, voxel_arg, address, out_dir)


def _prepare(world: World, req: _Request, csv_joints: bool) -> _Prepared:
    """The labelling job of the robot in the world's scene, and the box its end link can reach."""
    from robwot_sim.workspace.pool import spec_key

    model = world.robot_model(req.robot_id)
    out = _out_dir(req.out_dir)
    spec = world.scene_spec()
    for r in spec.get("robots", []):
        if r.get("id") == req.robot_id:
            r.pop("positions", None)  # irrelevant to labelling: keeps the workers' cached world valid
    fk = chain_fk(world, req.robot_id)
    lower, upper = model.limits()
    base_voxel = BASE_VOXEL if req.voxel == "auto" else float(req.voxel)
    t_reach = time.perf_counter()
    reach_min, reach_max = fk.reach_bounds(lower, upper, req.seed)
    t_reach = time.perf_counter() - t_reach
    header, row_format = csv_layout(len(model.controllable) if csv_joints else None, model.controllable)
    job = ChunkJob(spec_key(spec), spec, req.robot_id, fk, np.asarray(lower, dtype=np.float64),
                   np.asarray(upper, dtype=np.float64), req.seed, base_voxel, row_format, csv_joints,
                   model.followers())
    return _Prepared(out, job, header, reach_min, reach_max, t_reach)


def _label_on_cluster(address: str, req: _Request, prep: _Prepared, report: Progress) -> _Labelled:
    from robwot_sim.workspace.cluster import run_chunks

    run = run_chunks(address, prep.job, req.samples, prep.header, prep.out / POINT_CLOUD,
                     lambda done, total: report("collide", done, total), ALPHA_MAX_POINTS)
    return _Labelled(run.alpha_points, run.collision_free, run.lo, run.hi, run.reach, run.seconds)


def _label_locally(world: World, req: _Request, prep: _Prepared, report: Progress) -> _Labelled:
    """Streamed like a cluster run: each chunk's rows are written once the earlier ones are; the calling
    thread labels chunks no worker has started with ``world`` itself while the pool starts."""
    t1 = time.perf_counter()
    sink = ChunkSink(prep.job.voxel, ALPHA_MAX_POINTS, lambda _b: None)

    def write(f: BinaryIO) -> None:
        f.write((",".join(prep.header) + "\n").encode())
        sink.write = f.write
        job = replace(prep.job, checked_meshes=checked_meshes())
        Labelling(job, req.samples, req.workers).result(
            lambda done, total: report("collide", done, total),
            helper=lambda q: world.collision_free_batch(req.robot_id, q), sink=sink.add)

    atomic_write(prep.out / POINT_CLOUD, write)
    return _Labelled(sink.alpha_points(), sink.free, sink.lo, sink.hi, sink.reach, time.perf_counter() - t1)


def _load_shape_code() -> None:
    """Imports the alpha shape's code (scipy's spatial package) on a thread of its own, once per process.
    Started as the labelling begins, when this process only waits for its workers: the alpha shape then
    finds it loaded (an import of a module another thread is importing waits for it), and the backend's
    start, which the workers' start competes with for every core, does not pay for it."""
    if "robwot_sim.workspace.alpha_shape" not in sys.modules:
        threading.Thread(target=importlib.import_module, args=("robwot_sim.workspace.alpha_shape",),
                         name="robwot-shape-import", daemon=True).start()


def _shape(points: np.ndarray, alpha: float | str, report: Progress) -> Shape:
    from robwot_sim.workspace.alpha_shape import alpha_shape

    report("alpha", 0, 1)
    shape = alpha_shape(points, alpha)
    report("alpha", 1, 1)
    return shape


def _write(req: _Request, out: Path, shape: Shape, reach: ReachabilityMap,
           report: Progress) -> ReachabilityMap:
    """The surface and the reachability map written; the map as written (coarsened when ``auto``)."""
    report("write", 0, 2)
    report("write", 1, 2)
    write_stl(out / SURFACE, shape.vertices, shape.triangles)
    if req.voxel == "auto":
        reach = reach.auto()
    reach.write_csv(out / REACHABILITY)
    report("write", 2, 2)
    return reach


def _summary(req: _Request, prep: _Prepared, lab: _Labelled, shape: Shape, reach: ReachabilityMap,
             timings: dict[str, float]) -> dict[str, Any]:
    bounds: dict[str, list[float] | None] = (
        {"min": None, "max": None} if lab.lo is None or lab.hi is None
        else {"min": [float(v) for v in lab.lo], "max": [float(v) for v in lab.hi]})
    reach_min, reach_max = prep.reach_min, prep.reach_max
    if bounds["min"] is not None and bounds["max"] is not None:  # the box holds every sample, by construction
        reach_min, reach_max = np.minimum(reach_min, bounds["min"]), np.maximum(reach_max, bounds["max"])
    summary: dict[str, Any] = {
        "samples": req.samples, "collisionFree": lab.free, "bounds": bounds,
        "reachBounds": {"min": reach_min.tolist(), "max": reach_max.tolist()},
        "alpha": shape.alpha, "method": shape.method, "volume": shape.volume, "seed": req.seed,
        "reachability": {"file": REACHABILITY, "voxel": reach.voxel, "voxels": reach.voxels,
                         "directions": DIRECTIONS, "approachAxis": "z"},
        "timings": timings, "versions": versions()}
    if shape.warning is not None:
        summary["warning"] = shape.warning
    from robwot_sim.workspace.flat_shape import FlatShape

    if isinstance(shape, FlatShape):
        summary["halfThickness"] = shape.half_thickness
    return summary


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
    req = _request(robot_id, samples, seed, workers, alpha, reach_voxel, cluster, out_dir)
    report: Progress = progress or (lambda _s, _d, _t: None)
    prep = _prepare(world, req, csv_joints)
    report("sample", req.samples, req.samples)
    report("collide", 0, req.samples)
    _load_shape_code()
    lab = (_label_on_cluster(req.address, req, prep, report) if req.address is not None
           else _label_locally(world, req, prep, report))
    t2 = time.perf_counter()
    shape = _shape(lab.alpha_points, req.alpha, report)
    t3 = time.perf_counter()
    reach = _write(req, prep.out, shape, lab.reach, report)
    t4 = time.perf_counter()
    timings = {"sample": prep.reach_seconds, "collide": lab.seconds, "alpha": t3 - t2, "write": t4 - t3}
    return _summary(req, prep, lab, shape, reach, timings)
