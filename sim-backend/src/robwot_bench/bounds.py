"""Outer bounds side by side: ``python -m robwot_bench.bounds`` (``npm run bench:bounds``).

For each robot and scene, the same seeded configurations labelled by ``World.collision_free_batch``
without the outer bounds (``bounds=False``: the sure hits in numpy, then Bullet) and with them (the
default, ``robwot_sim/sim/outerbounds.py``, compiled), alternately in one process (the machine's load hits
both alike): wall time per configuration of each and their ratio, the share of rows the bounds find apart
from every other body, free of self-contact too, and sure hits, the labels that differ, and how many rows
Bullet itself labels differently when it checks them in reverse order (a grazing contact's points kept
from one check to the next would make some, without ``client.Recheck``). Rows the bounds decide
are checked by fresh Bullet distance queries, sure hits against Bullet's own label (``unsound`` must be
0). Prints the load average.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

from robwot_bench.reference import example_robot
from robwot_sim.model.urdf import pybullet_data_path
from robwot_sim.sim.kernels import kernels_ready
from robwot_sim.sim.outerbounds import SURE_HIT
from robwot_sim.sim.world import World

SCENES = Path(__file__).resolve().parents[3] / "examples" / "scenes"
BUNDLED = {"kuka": "kuka_iiwa/model.urdf", "panda": "franka_panda/panda.urdf",
           "xarm6": "xarm/xarm6_robot.urdf", "xarm6_gripper": "xarm/xarm6_with_gripper.urdf",
           "two_joint": "TwoJointRobot_wo_fixedJoints.urdf",
           "ur3": str(Path(__file__).resolve().parents[3] / "packages" / "cli" / "robots" / "ur3.urdf")}
REFERENCE = ["ur3_ros", "ur5", "ur10", "panda_ros", "z1", "xarm7", "kinova"]
#: decided rows checked by fresh distance queries per robot and scene
FRESH = 300


def _load(world: World, name: str) -> str:
    if name in BUNDLED:
        path = BUNDLED[name]
        urdf = path if Path(path).is_absolute() else str(pybullet_data_path() / path)
        return world.load_robot(urdf, robot_id="r").id
    r = example_robot(name.removesuffix("_ros"))
    return world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, robot_id="r").id


def _unsound(world: World, rid: str, qs: np.ndarray, apart: np.ndarray, free: np.ndarray) -> int:
    """Decided rows that fresh Bullet distance queries contradict (apart: no other body within 0; free:
    also no checked self pair touching)."""
    bounds = world.queries.outer_bounds(rid)
    body, cid = world.scene.entry(rid).bound.body, world.scene.bullet.cid
    links = [ln for ln in range(-1, pb.getNumJoints(body, physicsClientId=cid))
             if pb.getCollisionShapeData(body, ln, physicsClientId=cid)]
    bad = 0
    for i in np.flatnonzero(apart)[:FRESH]:
        world.set_joint_positions(rid, qs[i])
        near = any(c[8] <= 0.0 for other in world.scene.table.names if other != body
                   for c in pb.getClosestPoints(body, other, 0.0, physicsClientId=cid))
        touch = free[i] and any(c[8] <= 0.0 for a, b in bounds.pairs
                                for c in pb.getClosestPoints(body, body, 0.0, links[a], links[b],
                                                             physicsClientId=cid))
        bad += near or touch
    return bad


def setup(world: World, name: str, scene: str | None, samples: int, seed: int) -> tuple[str, np.ndarray]:
    """Robot ``name`` and example scene ``scene`` (if any) loaded into ``world``; its id and ``samples``
    seeded uniform configurations within its limits."""
    rid = _load(world, name)
    if scene:
        world.load_scene(SCENES / scene)
    lo, hi = world.robot_model(rid).limits()
    return rid, np.random.default_rng(seed).uniform(lo, hi, size=(samples, len(lo)))


def measure(name: str, scene: str | None, samples: int, seed: int) -> dict[str, float | int | str]:
    if not kernels_ready(timeout=300):
        raise SystemExit("bench-bounds: the outer bounds' kernels did not load")
    with World() as world:
        rid, qs = setup(world, name, scene, samples, seed)
        world.collision_free_batch(rid, qs[:100], bounds=True)  # builds every mirror world first
        times = {False: 0.0, True: 0.0}
        labels: dict[bool, list[np.ndarray]] = {False: [], True: []}
        block = max(1000, samples // 10)
        for a in range(0, samples, block):  # alternately, so a change of the machine's load hits both
            for bounds in (False, True):
                t0 = time.perf_counter()
                labels[bounds].append(world.collision_free_batch(rid, qs[a:a + block], bounds=bounds))
                times[bounds] += time.perf_counter() - t0
        old, new = np.concatenate(labels[False]), np.concatenate(labels[True])
        reverse = world.collision_free_batch(rid, qs[::-1], bounds=False)[::-1]
        outer = world.queries.outer_bounds(rid)
        apart = outer.apart(qs)
        free = np.zeros(samples, dtype=bool)
        free[apart] = outer.self_free(qs[apart])
        hits = outer.classify(qs, self_always=False, hits=True) == SURE_HIT
        unsound = _unsound(world, rid, qs, apart, free) + int((hits & old).sum())
    return {"robot": name, "scene": scene or "-", "samples": samples,
            "us_old": 1e6 * times[False] / samples, "us_new": 1e6 * times[True] / samples,
            "ratio": times[True] / max(times[False], 1e-12), "apart": float(apart.mean()),
            "free": float(free.mean()), "hits": float(hits.mean()), "differ": int((old != new).sum()),
            "order": int((old != reverse).sum()), "unsound": unsound}


Measure = Callable[[str, "str | None", int, int], dict[str, Any]]


def sweep(doc: str, tag: str, measure: Measure, columns: list[tuple[str, str, str]], scenes: str) -> None:
    """The command line of a per-robot, per-scene bench: ``--robots``, ``--scenes`` (``-``: none),
    ``--samples``, ``--seed``; one row per robot and scene of the ``columns`` (result key, header, format
    spec of the value) of ``measure(robot, scene, samples, seed)``, with the load average before and
    after."""
    p = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robots", default=",".join([*BUNDLED, *REFERENCE]))
    p.add_argument("--scenes", default=scenes)
    p.add_argument("--samples", type=int, default=100_000)
    p.add_argument("--seed", type=int, default=26)
    args = p.parse_args()
    print(f"{tag}: {args.samples} samples per robot and scene; load average "
          + " ".join(f"{x:.2f}" for x in os.getloadavg()), flush=True)
    width = {key: max(len(header), 6) for key, header, _ in columns}
    print(f"{'robot':14s} {'scene':20s} " + " ".join(f"{h:>{width[k]}s}" for k, h, _ in columns), flush=True)
    for name in args.robots.split(","):
        for scene in args.scenes.split(","):
            r = measure(name, None if scene == "-" else scene, args.samples, args.seed)
            print(f"{r['robot']:14s} {r['scene']:20s} "
                  + " ".join(f"{r[k]:>{width[k]}{spec}}" for k, _, spec in columns), flush=True)
    print("load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


def main() -> None:
    sweep(__doc__ or "", "bench-bounds", measure,
          [("us_old", "us old", ".1f"), ("us_new", "us new", ".1f"), ("ratio", "new/old", ".2f"),
           ("apart", "apart", ".3f"), ("free", "free", ".3f"), ("hits", "hits", ".3f"),
           ("differ", "differ", "d"),
           ("order", "order", "d"), ("unsound", "unsound", "d")], "-,obstacles-4.json,obstacles-239.json")


if __name__ == "__main__":
    main()
