"""The outer bounds' compiled kernels (``sphere_kernel.py``, ``gjk_kernel.py``, ``hit_kernel.py``,
``pair_kernel.py``, ``bounds_kernel.py``) in a process: loaded once, from numba's disk cache (compiled on a
machine's first use), on a thread of their own or in the caller's; until they are loaded the bounds know
nothing and every check runs on Bullet alone (``outerbounds.py``)."""

from __future__ import annotations

import contextlib
import hashlib
import os
import sys
import threading
from pathlib import Path
from typing import Any

import numpy as np

from robwot_sim.wholefile import atomic_write

#: rows a process labels before it loads the kernels and builds each robot's shapes: the fixed cost (numba's
#: import and compiler, the kernels' load: about half a second and 100 MB; a robot's shapes, fitted once per
#: machine: ``shape_cache.py``) is paid back only over many rows; path checks use the bounds once loaded
#: and never load them: loading holds the backend's loop for up to a second or more at a time (numba's
#: import and LLVM, in C, with the GIL), which only a servient's start (``planning.warmUp``) affords. The
#: labelling workers have them from their first row: their forkserver loads them (``workspace/preload.py``)
WARM_AFTER = 100_000
#: s to wait for the kernels where a caller must have them (a machine's first use compiles them)
KERNELS_WAIT = 900.0
_asked = 0
_kernels_ready = threading.Event()
_kernels_lock = threading.Lock()
_kernels_started = False
_kernels_ok = False


def load_kernels(here: bool = False) -> None:
    """Loads the compiled kernels (``sphere_kernel.py``: numba's import and, from its disk cache, or
    compiled on a machine's first use, every kernel) on a thread of their own, once per process (once it
    has labelled ``WARM_AFTER`` rows, or when told to: ``kernels_ready``, ``planning.warmUp``); until they are
    loaded the outer bounds know nothing (every check runs on Bullet alone) instead of making a caller
    wait. ``here``: in the calling thread, returning once they are loaded (the labelling pool's forkserver,
    whose workers then have them from their first row: ``workspace/preload.py``). A cache numba cannot read
    (one written by another version of the kernels) is emptied and the kernels compiled again; kernels
    that still fail to load leave the bounds empty for good, said once on stderr.
    ``ROBWOT_OUTER_BOUNDS=off`` in the environment leaves them unloaded: every check on Bullet alone (to
    compare, or where numba cannot run)."""
    global _kernels_started
    with _kernels_lock:
        if _kernels_started:
            return
        _kernels_started = True
    if os.environ.get("ROBWOT_OUTER_BOUNDS") == "off":
        _kernels_ready.set()
        return

    def load() -> None:
        global _kernels_ok
        try:
            caches, stamp, sources = _kernel_caches()
            flush_stale(caches, stamp, sources)
            try:
                _warm()
            except Exception:  # e.g. a cache naming types this version no longer has: compile again
                for cache in caches:
                    cache.flush()
                _warm()
            _kernels_ok = True
            with contextlib.suppress(OSError):
                write_stamp(stamp, sources)
        except Exception as err:  # the bounds stay empty: every check runs on Bullet alone
            print(f"robwot: the outer bounds' compiled kernels did not load ({err!r}); checks run on Bullet "
                  "alone", file=sys.stderr)
        finally:
            _kernels_ready.set()

    if here:
        load()
    else:
        threading.Thread(target=load, name="robwot-kernels", daemon=True).start()


def write_stamp(stamp: Path, sources: str) -> None:
    """``stamp`` made to hold ``sources``: untouched when it already does, else written whole (a temporary
    file renamed over it). Every process that loads the kernels writes it while others read it
    (``flush_stale``): a stamp read half-written would empty every cache and make every process compile
    the kernels again, for minutes."""
    try:
        if stamp.read_text() == sources:
            return
    except (OSError, UnicodeDecodeError):
        pass
    atomic_write(stamp, lambda f: f.write(sources.encode()))


def flush_stale(caches: list[Any], stamp: Path, sources: str) -> None:
    """Every cache emptied unless ``stamp`` holds ``sources`` (the kernels' sources they were compiled from:
    ``_kernel_caches``); an unreadable stamp counts as another."""
    try:
        same = stamp.read_text() == sources
    except (OSError, UnicodeDecodeError):
        same = False
    if not same:
        for cache in caches:
            cache.flush()


def _kernel_caches() -> tuple[list[Any], Path, str]:
    """numba's disk caches of every kernel, the stamp file beside them and the digest of the kernels' sources
    it must hold. numba keys a kernel's cache by its own file only, but a kernel holds a copy of every kernel
    it calls from the other files (inlined or linked in): a change to any of the files compiles all."""
    from numba.core.registry import CPUDispatcher

    from robwot_sim.sim import bounds_kernel, gjk_kernel, hit_kernel, pair_kernel, sphere_kernel
    modules = (sphere_kernel, gjk_kernel, hit_kernel, pair_kernel, bounds_kernel)
    found = [getattr(k, "_cache", None) for m in modules for k in vars(m).values()
             if isinstance(k, CPUDispatcher)]
    caches = [c for c in found if c is not None]
    digest = hashlib.sha256(b"".join(Path(str(m.__file__)).read_bytes() for m in modules)).hexdigest()
    return caches, Path(caches[0]._cache_path) / "robwot-kernels.sha256", digest


def asked(rows: int) -> bool:
    """Counts ``rows`` more configurations asked about in this process; whether the outer bounds are
    wanted yet (``WARM_AFTER`` reached, or the kernels already loading: ``load_kernels``)."""
    global _asked
    _asked += rows
    return _kernels_started or _asked >= WARM_AFTER


def kernels_loaded() -> bool:
    """Whether the kernels are loaded in this process (never starts loading them)."""
    return _kernels_ready.is_set() and _kernels_ok


def kernels_ready(timeout: float = 0.0) -> bool:
    """Whether the kernels are loaded (``load_kernels``, started if not yet), waiting up to ``timeout`` s."""
    load_kernels()
    return _kernels_ready.wait(timeout) and _kernels_ok


def _warm() -> None:
    """Every kernel called once with the types the bounds call it with (so each is loaded from numba's
    cache, or compiled): a one-joint arm with one box part beside a box."""
    from robwot_sim.sim.joint_tree import Tree, tree_frames
    from robwot_sim.sim.outerbounds import GRID_SIDE, ZONE_SIDE, Bodies, OuterBounds, distance_grid
    from robwot_sim.sim.pair_tables import pair_tables
    from robwot_sim.sim.robot_shapes import LinkShapes, RobotShapes, shapes_of

    # the box's shapes written out, not fitted: the fitting code (scipy's) is no kernel, and a process
    # labelling a robot whose shapes are cached never loads it
    box = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (0.0, 0.5)])
    planes = np.array([[1.0, 0, 0, -0.1], [-1.0, 0, 0, -0.1], [0, 1.0, 0, -0.1], [0, -1.0, 0, -0.1],
                       [0, 0, 1.0, -0.5], [0, 0, -1.0, 0]])  # n . x + offset <= 0 inside
    fitted = {"centres": np.array([[0.0, 0.0, 0.25]]), "radii": np.array([0.3]),
              "sphere_part": np.zeros(1, dtype=np.int64), "box_c": np.array([[0.0, 0.0, 0.25]]),
              "box_axes": np.eye(3)[None].copy(), "box_half": np.array([[0.1, 0.1, 0.25]]), "verts": [box],
              "corners": [box], "faces": [planes], "hull": [box], "inner_c": np.zeros((1, 3)),
              "inner_r": np.array([0.05])}
    link = LinkShapes.made(0, True, fitted, np.ones(1, dtype=np.bool_))
    tree = Tree(np.array([-1], dtype=np.int64), np.array([1], dtype=np.int64), np.zeros((1, 3)),
                np.eye(3)[None].copy(), np.array([[0.0, 0.0, 1.0]]), np.ones((1, 1)), np.zeros(1),
                np.zeros(3), np.eye(3))
    shapes = shapes_of([link, link], [0, -1], [(0, 1)], [(0, 1)])
    robot = RobotShapes(tree, (link, link), ((0, 1),), shapes, 1.0,
                        pair_tables(tree, shapes, np.full(1, -1.0), np.ones(1)))
    bodies = Bodies(np.zeros(1, dtype=np.int64), np.full((1, 3), 0.05), np.array([[0.3, 0.0, 0.2]]),
                    np.eye(3)[None].copy(), np.ones(1, dtype=np.bool_))
    bounds = OuterBounds(robot, bodies, distance_grid(bodies, 0.2, None, GRID_SIDE),
                         distance_grid(bodies, 0.3, None, ZONE_SIDE))
    tree_frames(tree, np.zeros(1))
    bounds.classify(np.zeros((1, 1)), hits=True)
    bounds.fill_tables()
