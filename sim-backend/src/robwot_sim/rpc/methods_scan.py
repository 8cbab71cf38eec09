"""`scene.fromScan` (a conservative scene from point clouds: ``scan/``) and `camera.capture` (a depth image
of the world written as a point cloud: ``sim/camera.py``). Neither changes the world: the clouds are read
and covered off the world's thread, which only hands over the robots' shapes or casts the camera's rays.
The scan modules (and scipy's spatial, sparse and image code under them) load at the first
``scene.fromScan``, not with the backend."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from robwot_sim.errors import FileNotFound
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.scan.clouds import write_ply
from robwot_sim.sim.camera import Camera, camera_points, depth_image, orientation
from robwot_sim.sim.world_thread import Kind

if TYPE_CHECKING:
    from robwot_sim.scan.scene_from_scan import Placed, ScanParams


def _params(p: Params) -> ScanParams:
    from robwot_sim.scan.fit import load_model
    from robwot_sim.scan.scene_from_scan import ScanParams

    models = tuple(load_model(str(m["name"]), str(m["file"])) for m in p["models"] or [])
    return ScanParams(models=models, noise=float(p["noise"]), shape=str(p["shape"]), voxel=float(p["voxel"]),
                      gap=float(p["gap"]), padding=float(p["robotPadding"]), occluded=str(p["occluded"]),
                      reach=float(p["reach"]),
                      mesh_dir=Path(p["meshDir"]).expanduser() if p.has("meshDir") else None)


def _place(clouds: list[dict[str, Any]]) -> Placed:
    """The clouds read and placed; a missing file named as such."""
    from robwot_sim.scan.scene_from_scan import place_clouds

    try:
        return place_clouds(clouds)
    except FileNotFoundError as e:
        raise FileNotFound(str(e.filename), what="point cloud") from None
    except IsADirectoryError as e:
        raise FileNotFound(str(e.filename), what="point cloud (a folder, not a file)") from None


def register(d: Dispatcher, s: Services) -> None:
    @d.method("scene.fromScan")
    async def from_scan(p: Params, call: Call) -> dict[str, Any]:
        from robwot_sim.scan.robot_points import snapshot
        from robwot_sim.scan.scene_from_scan import scene_from_scan

        params = await s.off_world(lambda: _params(p))
        placed = await s.off_world(lambda: _place(list(p["clouds"])), background=True)
        robots = await s.on_world(lambda: snapshot(s.world.scene), Kind.PLAIN)
        return await s.off_world(lambda: scene_from_scan(placed, robots, params), background=True)

    @d.method("camera.capture")
    async def capture(p: Params, call: Call) -> dict[str, Any]:
        camera = Camera(np.asarray(p.floats("position")), np.asarray(p.floats("target")),
                        np.array([0.0, 0.0, 1.0]), int(p["width"]), int(p["height"]), float(p["fov"]),
                        0.0, float(p["far"]))
        rng = np.random.default_rng(int(p["seed"]))
        cid = s.world.scene.bullet.cid
        noise, dropout = float(p["noise"]), float(p["dropout"])
        depth = await s.on_world(lambda: depth_image(cid, camera, noise, dropout, rng), Kind.PLAIN)
        points, quat = camera_points(depth, camera), orientation(camera)
        position = [float(v) for v in camera.position]
        await s.off_world(lambda: write_ply(Path(p["file"]).expanduser(), points, [*position, *quat]))
        return {"file": str(Path(p["file"]).expanduser().resolve()), "points": len(points),
                "position": position, "orientation": [float(v) for v in quat]}
