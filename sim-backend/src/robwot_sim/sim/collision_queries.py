"""Batch collision queries over a scene, and the caches they keep (MoveIt's collision environment).

A batch labels many configurations of one robot at once. Three tests keep it cheap, each built from the
scene and kept until the scene changes: the sure-hit test (``surehit.py``, keyed by the scene's
version), the free-for-sure outer bounds (``outerbounds.py``, keyed by everything but the robot's own
joints: ``others_stamp``) and the collision-only mirror worlds (``fastworld.py``, the whole scene or one
robot alone, keyed by the scene's version). The queries read the scene and never change it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams
from robwot_sim.sim.fastworld import FastWorld, MirrorRobot
from robwot_sim.sim.outerbounds import OuterBounds, build_outer_bounds
from robwot_sim.sim.planning_scene import Scene
from robwot_sim.sim.surehit import SureHits, build_sure_hits


class CollisionQueries:
    """Batch collision checks of one robot's configurations against a scene. ``close()`` frees the
    mirror worlds."""

    def __init__(self, scene: Scene) -> None:
        self._scene = scene
        self._fast: FastWorld | None = None  # collision-only mirror for batches, rebuilt on change
        self._alone: dict[str, FastWorld] = {}  # per robot: a mirror of it alone (its self-contact)
        self._sure: dict[str, tuple[int, SureHits]] = {}  # sure-hit tests by robot, with the version
        self._outer: dict[str, tuple[tuple[int, int], OuterBounds]] = {}  # by robot, with others_stamp

    def close(self) -> None:
        for fast in [self._fast, *self._alone.values()]:
            if fast is not None:
                fast.close()
        self._fast, self._alone = None, {}

    def free_batch(self, robot_id: str, qs: npt.NDArray[np.float64],
                   bounds: bool = False) -> npt.NDArray[np.bool_]:
        """Collision-free flag per configuration (rows of ``qs`` [n, dof]); restores the state. With
        ``bounds``, rows the outer bounds (``outerbounds.py``) find apart from every other body are checked
        for self-contact in a world holding the robot alone, and rows also free of self-contact for sure
        are not checked by Bullet (off by default: on the robots and scenes measured, the numpy tests cost
        as much as the Bullet work they save; ``python -m robwot_bench.bounds``)."""
        e = self._scene.entry(robot_id)
        entries = self._scene.entries()
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
        todo = np.flatnonzero(~self.sure_hits(robot_id).hits(arr))
        if e.checker.massless_moving:
            out[todo] = e.checker.batch(arr[todo])
            return out
        if bounds:
            outer = self.outer_bounds(robot_id)
            apart = outer.apart(arr[todo])
            alone, todo = todo[apart], todo[~apart]
            sure_free = outer.self_free(arr[alone])
            out[alone[sure_free]] = True
            alone = alone[~sure_free]
            out[alone] = self.mirror(robot_id).batch(robot_id, arr[alone], {}, e.bound.followers)
        others = {rid: o.bound.full_values(o.bound.q) for rid, o in entries.items() if rid != robot_id}
        out[todo] = self.mirror().batch(robot_id, arr[todo], others, e.bound.followers)
        return out

    def outer_bounds(self, robot_id: str) -> OuterBounds:
        """The robot's free-for-sure test (``outerbounds.py``), rebuilt when anything else changes."""
        stamp = self._scene.others_stamp(robot_id)
        cached = self._outer.get(robot_id)
        if cached is not None and cached[0] == stamp:
            return cached[1]
        entries = self._scene.entries()
        e = entries[robot_id]
        others = [o.bound for rid, o in entries.items() if rid != robot_id]
        bounds = build_outer_bounds(e.bound, e.checker.filtered, e.model, self._scene.obstacle_bodies(),
                                    others)
        self._outer[robot_id] = (stamp, bounds)
        return bounds

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
