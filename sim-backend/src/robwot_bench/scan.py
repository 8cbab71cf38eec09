"""Scan benchmark: ``python -m robwot_bench.scan`` (``npm run bench:scan`` runs it, then the live part).

A cloud of about 200,000 points is rendered once by the depth camera (``sim/camera.py``) over the KUKA on
its table (examples/scenes/table.json; 1 mm noise at 1 m, 1 % dropped pixels) and written as a binary PLY;
then, per cover (``--shapes``), the whole of ``scene.fromScan`` is timed in process: reading the file,
removing the robot's points, finding the supports, clustering and covering the objects, their shadows.
Prints per cover the median and p95 wall time of the whole and the median of each stage, and the load
average. The robots' shapes are taken once, as the backend takes them once per request.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from robwot_sim.scan.clouds import read_cloud, write_ply
from robwot_sim.scan.robot_points import robot_mask, snapshot
from robwot_sim.scan.scene_from_scan import ScanParams, place_clouds, scene_from_scan
from robwot_sim.scan.segment import find_supports
from robwot_sim.sim.camera import Camera, camera_points, depth_image, orientation
from robwot_sim.sim.world import World

WIDTH, HEIGHT = 800, 600
SCENE = Path(__file__).resolve().parents[3] / "examples" / "scenes" / "table.json"


def _cloud(world: World, folder: Path) -> Path:
    """The benchmark's cloud: one 800 x 600 depth image of the table from the front, above."""
    cam = Camera(np.array([1.0, 0.1, 0.8]), np.array([0.3, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]),
                 WIDTH, HEIGHT, 1.3, 0.0, 5.0)
    depth = depth_image(world.scene.bullet.cid, cam, 0.001, 0.01, np.random.default_rng(1))
    file = folder / "bench.ply"
    write_ply(file, camera_points(depth, cam), [*cam.position, *orientation(cam)])
    return file


def _stages(file: Path, robots: Any, params: ScanParams) -> dict[str, float]:
    """Wall seconds of each stage once: read, robot points, supports (the rest: covers and shadows)."""
    t0 = time.perf_counter()
    read_cloud(file)
    t1 = time.perf_counter()
    placed = place_clouds([{"file": str(file)}])
    keep = ~robot_mask(placed.points, robots, params.padding)
    t2 = time.perf_counter()
    find_supports(placed.points[keep], params.noise)
    t3 = time.perf_counter()
    return {"read": t1 - t0, "robots": t2 - t1 - (t1 - t0), "supports": t3 - t2}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=9, help="timed runs per cover (default 9)")
    parser.add_argument("--shapes", default="box,tightest,voxels",
                        help="covers timed (default box,tightest,voxels)")
    args = parser.parse_args()
    world = World()
    world.load_scene(str(SCENE))
    robots = snapshot(world.scene)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        file = _cloud(world, folder)
        points = len(read_cloud(file).points)
        print(f"cloud: {points} points (one 800 x 600 depth image of examples/scenes/table.json), "
              f"load average {os.getloadavg()[0]:.2f}")
        print(f"{'cover':10} {'median ms':>10} {'p95 ms':>8} {'read':>6} {'robots':>7} {'supports':>9} "
              f"{'objects':>8} {'obstacles':>10}")
        for shape in args.shapes.split(","):
            params = ScanParams(noise=0.005, shape=shape, mesh_dir=folder / shape)
            times, stages, result = [], [], {}
            for _ in range(args.runs):
                t = time.perf_counter()
                result = scene_from_scan(place_clouds([{"file": str(file)}]), robots, params)
                times.append(time.perf_counter() - t)
                stages.append(_stages(file, robots, params))
            med = {k: 1e3 * statistics.median(s[k] for s in stages) for k in stages[0]}
            p95 = sorted(times)[max(0, round(0.95 * len(times)) - 1)]
            print(f"{shape:10} {1e3 * statistics.median(times):10.1f} {1e3 * p95:8.1f} {med['read']:6.1f} "
                  f"{med['robots']:7.1f} {med['supports']:9.1f} {len(result['objects']):8d} "
                  f"{len(result['obstacles']):10d}")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
