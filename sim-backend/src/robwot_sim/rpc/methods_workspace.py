"""`workspace.generate`: blocking generation in a thread of its own (off the world's thread: it waits on
its worker processes for minutes), progress as notifications; the few world calls it makes go to the
world's thread (`_WorldCalls`). `workspace.warmUp`: start the collision worker pool ahead of time."""

from __future__ import annotations

import os
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from robwot_sim.model.robot_model import RobotModel
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import generate_workspace
from robwot_sim.workspace.pool import warm_up


def _workers(p: Params) -> int:
    return int(p["workers"] if p.has("workers") else min(os.cpu_count() or 1, 256))


class _WorldCalls:
    """The `World` methods `generate_workspace` calls, each run on the world's thread (the generation
    itself runs on another one): the short labelling batches of the helping caller included."""

    def __init__(self, s: Services) -> None:
        self._s = s

    def robot_model(self, robot_id: str) -> RobotModel:
        return self._s.call_world(lambda: self._s.world.robot_model(robot_id))

    def scene_spec(self) -> dict[str, Any]:
        return self._s.call_world(self._s.world.scene_spec)

    def collision_free_batch(self, robot_id: str, qs: npt.NDArray[np.float64]) -> npt.NDArray[np.bool_]:
        return self._s.call_world(lambda: self._s.world.collision_free_batch(robot_id, qs))


def register(d: Dispatcher, s: Services) -> None:
    @d.method("workspace.warmUp")
    async def warm(p: Params, call: Call) -> dict[str, Any]:
        workers = _workers(p)
        warm_up(workers)
        return {"workers": workers}

    @d.method("workspace.generate")
    async def generate(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        samples, seed, workers = int(p["samples"]), int(p["seed"]), _workers(p)
        alpha: float | str = p["alpha"] if p["alpha"] == "auto" else float(p["alpha"])
        out_dir, csv_joints = str(p["outDir"]), bool(p["csvJoints"])
        reach_voxel: float | str = p["reachVoxel"] if p["reachVoxel"] == "auto" else float(p["reachVoxel"])
        cluster = str(p["cluster"]) if p.has("cluster") else None
        progress = s.threadsafe(call.notify)

        def report(stage: str, done: int, total: int) -> None:
            progress("workspace.progress", {"stage": stage, "done": done, "total": total})

        def run() -> dict[str, Any]:
            return generate_workspace(cast(World, _WorldCalls(s)), model.id, samples=samples, seed=seed,
                                      workers=workers, alpha=alpha, out_dir=out_dir, csv_joints=csv_joints,
                                      reach_voxel=reach_voxel, cluster=cluster, progress=report)

        return await s.off_world(run)
