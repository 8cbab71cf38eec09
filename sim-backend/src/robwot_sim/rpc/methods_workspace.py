"""`workspace.generate`: blocking generation in a worker thread, progress as notifications.
`workspace.warmUp`: start the collision worker pool (and load the alpha-shape code) ahead of time."""

from __future__ import annotations

import os
from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params, invalid_param
from robwot_sim.rpc.services import Services
from robwot_sim.workspace import generate_workspace, warm_up


def register(d: Dispatcher, s: Services) -> None:
    @d.method("workspace.warmUp", ("workers",),
              "start the collision worker pool in the background, so a coming generation does not wait")
    async def warm(p: Params, call: Call) -> dict[str, Any]:
        workers = p.integer("workers", os.cpu_count() or 1, minimum=1, maximum=256)
        warm_up(workers, preload=True)
        return {"workers": workers}

    @d.method("workspace.generate",
              ("robot", "samples", "seed", "workers", "alpha", "outDir", "csvJoints"),
              "sample the reachable, collision-free workspace; write workspace.csv and workspace.stl")
    async def generate(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        samples = p.integer("samples", 80_000, minimum=1, maximum=10_000_000)
        seed = p.integer("seed", 1, minimum=0, maximum=2**32 - 1)
        workers = p.integer("workers", os.cpu_count() or 1, minimum=1, maximum=256)
        alpha: float | str = "auto"
        if p.has("alpha") and p.raw["alpha"] != "auto":
            if isinstance(p.raw["alpha"], str):
                raise invalid_param("alpha", '"auto" or a radius in metres > 0', p.raw["alpha"])
            alpha = p.number("alpha", minimum=0.0, exclusive_minimum=True)
        out_dir = p.string("outDir")
        csv_joints = p.boolean("csvJoints", False)
        progress = s.threadsafe(call.notify)

        def report(stage: str, done: int, total: int) -> None:
            progress("workspace.progress", {"stage": stage, "done": done, "total": total})

        def run() -> dict[str, Any]:
            return generate_workspace(s.world, model.id, samples=samples, seed=seed, workers=workers,
                                      alpha=alpha, out_dir=out_dir, csv_joints=csv_joints, progress=report)

        return await s.run_blocking(run)
