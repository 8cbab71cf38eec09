"""Batch collision queries over a scene, and the caches they keep (MoveIt's collision environment).

A batch labels many configurations of one robot at once. Three tests keep it cheap, each built from the
scene and kept until the scene changes: the free-for-sure outer bounds (``outerbounds.py``, compiled;
the scene keeps them, as path checks use them too), the sure-hit test (``surehit.py``,
keyed by the scene's version) and the collision-only mirror worlds (``fastworld.py``, the whole scene or one
robot alone, keyed by the scene's version). The queries read the scene and never change it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams
from robwot_sim.sim.fastworld import FastWorld, MirrorRobot
from robwot_sim.sim.outerbounds import SURE_HIT, OuterBounds
from robwot_sim.sim.planning_scene import Scene
from robwot_sim.sim.surehit import SureHits, build_sure_hits

#: rows of a batch the outer bounds try first, and the share of them they must decide to be used
PROBE, MIN_DECIDED = 500, 0.2


class CollisionQueries:
    """Batch collision checks of one robot's configurations against a scene. ``close()`` frees the
    mirror worlds."""

    def __init__(self, scene: Scene) -> None:
        self._scene = scene
        self._fast: FastWorld | None = None  # collision-only mirror for batches, rebuilt on change
        self._alone: dict[str, FastWorld] = {}  # per robot: a mirror of it alone (its self-contact)
        self._sure: dict[str, tuple[int, SureHits]] = {}  # sure-hit tests by robot, with the version
        self._paying: dict[str, tuple[OuterBounds, bool]] = {}  # whether the outer bounds pay, by robot

    def close(self) -> None:
        for fast in [self._fast, *self._alone.values()]:
            if fast is not None:
                fast.close()
        self._fast, self._alone = None, {}

    def free_batch(self, robot_id: str, qs: npt.NDArray[np.float64],
                   bounds: bool = True) -> npt.NDArray[np.bool_]:
        """Collision-free flag per configuration (rows of ``qs`` [n, dof]); restores the state. Rows the
        outer bounds (``outerbounds.py``) find free for sure are not checked by Bullet, rows they find
        apart from every other body are checked for self-contact in a world holding the robot alone; of
        the rest, the sure hits (``surehit.py``'s test, compiled with the bounds) are colliding and Bullet
        checks the others in the main world. ``bounds=False``, bounds the robot cannot have, or a process
        that has not asked about enough rows yet (``kernels.WARM_AFTER``): the sure hits in numpy, no
        outer bounds (``python -m robwot_bench.bounds`` compares)."""
        e = self._scene.entry(robot_id)
        arr = _rows(qs, e.bound.dof)
        bad = (
            ~np.isfinite(arr).all(axis=1)
            | (arr < e.bound.lower - 1e-9).any(axis=1)
            | (arr > e.bound.upper + 1e-9).any(axis=1)
        )
        if bad.any():
            e.bound.validate(arr[int(np.argmax(bad))], f"qs[{int(np.argmax(bad))}]")
        if e.checker.static_contacts():
            return np.zeros(len(arr), dtype=bool)
        out = np.zeros(len(arr), dtype=bool)
        outer = self._scene.bounds.get(self._scene, robot_id, len(arr)) if bounds else OuterBounds()
        probe = None if outer.empty else self._probe(robot_id, outer, arr)
        if probe is not None:
            rest = outer.classify(arr[len(probe):], self_always=False, hits=True)
            status = np.concatenate([probe, rest])
            out[status == 0] = True
            todo = np.flatnonzero((status != 0) & (status != SURE_HIT))
            if not e.checker.massless_moving:  # the mirrors do not check massless links
                alone = todo[status[todo] == 2]
                if len(alone):  # a mirror is built only for rows that need it
                    out[alone] = self.mirror(robot_id).batch(robot_id, arr[alone], self._states(robot_id),
                                                             e.bound.followers)
                todo = todo[status[todo] != 2]
        else:
            todo = np.flatnonzero(~self.sure_hits(robot_id).hits(arr))
        if e.checker.massless_moving or probe is not None:
            # the rows the outer bounds leave lie near other bodies, where Bullet's narrow phase dominates:
            # the main world checks them as fast as the mirror merging the obstacles, with nothing to build
            out[todo] = e.checker.batch(arr[todo])
            return out
        if len(todo):
            out[todo] = self.mirror().batch(robot_id, arr[todo], self._states(), e.bound.followers)
        return out

    def _states(self, robot_id: str | None = None) -> dict[str, list[float]]:
        """Every robot's state (``robot_id``'s alone) as a mirror sets it (`FastWorld.batch`)."""
        return {rid: o.bound.full_values(o.bound.q) for rid, o in self._scene.entries().items()
                if robot_id in (None, rid)}

    def _probe(self, robot_id: str, outer: OuterBounds, arr: npt.NDArray[np.float64]) -> Any:
        """Whether the outer bounds decide enough rows of this robot and scene to pay: at least
        ``MIN_DECIDED`` of the first batch's first ``PROBE`` rows (a robot whose links always come within
        the bounds' gap of each other, such as a gripper's knuckles, decides none), the verdict kept until
        the bounds are rebuilt. None when they do not pay, else the status of the rows classified to find
        out (none once known)."""
        cached = self._paying.get(robot_id)
        if cached is not None and cached[0] is outer:
            return np.zeros(0, dtype=np.int8) if cached[1] else None
        if len(arr) < PROBE:
            return np.zeros(0, dtype=np.int8)
        status = outer.classify(arr[:PROBE], self_always=False, hits=True)
        pays = bool(((status == 0) | (status == SURE_HIT)).mean() >= MIN_DECIDED)
        self._paying[robot_id] = (outer, pays)
        return status if pays else None

    def outer_bounds(self, robot_id: str) -> OuterBounds:
        """The robot's free-for-sure test (``outerbounds.py``, kept by the scene)."""
        return self._scene.bounds.get(self._scene, robot_id)

    def sure_hits(self, robot_id: str) -> SureHits:
        """The robot's sure-hit test (``surehit.py``), rebuilt when the scene changes."""
        version = self._scene.version
        cached = self._sure.get(robot_id)
        if cached is not None and cached[0] == version:
            return cached[1]
        e = self._scene.entries()[robot_id]
        sure = build_sure_hits(e.bound, e.checker.filtered, e.model, self._scene.built_specs())
        self._sure[robot_id] = (version, sure)
        return sure

    def mirror(self, alone: str | None = None) -> FastWorld:
        """The collision-only mirror of the scene (``fastworld.py``), or of robot ``alone`` by itself."""
        version = self._scene.version
        cached = self._fast if alone is None else self._alone.get(alone)
        if cached is not None and cached.version == version:
            return cached
        if cached is not None:
            cached.close()
        mirror = {
            rid: MirrorRobot(e.urdf_path, e.package_roots, e.model.base_position, e.model.base_orientation,
                             e.bound.set_idx, e.checker.filtered)
            for rid, e in self._scene.entries().items() if alone is None or rid == alone
        }
        obstacles = self._scene.built_specs() if alone is None else []
        fast = FastWorld(mirror, obstacles, version)
        if alone is None:
            self._fast = fast
        else:
            self._alone[alone] = fast
        return fast


def _rows(qs: Any, dof: int) -> npt.NDArray[np.float64]:
    """``qs`` as an array [n, dof], or InvalidParams."""
    try:
        arr = np.asarray(qs, dtype=np.float64)
    except (TypeError, ValueError):
        arr = np.zeros((0,))
    if arr.ndim != 2 or arr.shape[1] != dof:
        raise InvalidParams(f"expected an array [n, {dof}]", param="qs", expected=f"[n, {dof}]",
                            got=list(arr.shape))
    return arr
