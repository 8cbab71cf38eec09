"""Backend benchmark: ``python -m robwot_bench.backend`` (``npm run bench:backend``).

Prints a plain text table for kuka and panda: IK success and median/p99 time (position and pose targets
from seeded random configurations, collision-free solutions requested), FK configurations/s, and
collision checks/s (``World.collision_free_batch``, one process) with the example scenes of
0/4/66/135/239 obstacles. Wall-clock and process CPU rates are both shown: on a shared machine the CPU
rate is the one that measures the code.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from robwot_sim.errors import Unreachable
from robwot_sim.sim.world import World

ROBOTS = {"kuka": "kuka_iiwa/model.urdf", "panda": "franka_panda/panda.urdf"}
SCENE_SIZES = (0, 4, 66, 135, 239)
SCENES = Path(__file__).resolve().parents[3] / "examples" / "scenes"


def _limits(w: World, rid: str) -> tuple[np.ndarray, np.ndarray]:
    m = w.robot_model(rid)
    return m.limits()


def bench_ik(w: World, rid: str, n: int, orientation: bool) -> tuple[float, float, float]:
    """(success rate, median ms, p99 ms) over n targets from random configurations."""
    lo, hi = _limits(w, rid)
    rng = np.random.default_rng(11)
    times, ok = [], 0
    for _ in range(n):
        target = w.fk(rid, rng.uniform(lo, hi))
        t0 = time.perf_counter()
        try:
            r = w.ik(rid, target.position, target.quat_xyzw if orientation else None)
        except Unreachable:
            times.append(time.perf_counter() - t0)
            continue
        times.append(time.perf_counter() - t0)
        ok += r.position_error <= 1e-3 and r.orientation_error <= math.radians(1)
    t = np.array(times) * 1e3
    return ok / n, float(np.median(t)), float(np.percentile(t, 99))


def bench_fk(w: World, rid: str, n: int) -> tuple[float, float]:
    """(configurations/s wall, configurations/s CPU) of ``World.fk(q)`` (validation + FK + state restore)."""
    lo, hi = _limits(w, rid)
    qs = np.random.default_rng(12).uniform(lo, hi, size=(n, len(lo)))
    t0, c0 = time.perf_counter(), time.process_time()
    for q in qs:
        w.fk(rid, q)
    return n / (time.perf_counter() - t0), n / max(time.process_time() - c0, 1e-9)


def bench_collision(urdf: str, obstacles: int, n: int) -> tuple[float, float, float]:
    """(checks/s wall, checks/s CPU, collision-free fraction) of collision_free_batch."""
    with World() as w:
        rid = w.load_robot(urdf).id
        if obstacles:
            w.load_scene(SCENES / f"obstacles-{obstacles}.json")
        lo, hi = _limits(w, rid)
        qs = np.random.default_rng(13).uniform(lo, hi, size=(n, len(lo)))
        w.collision_free_batch(rid, qs[:50])  # warm caches
        t0, c0 = time.perf_counter(), time.process_time()
        free = w.collision_free_batch(rid, qs)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return n / wall, n / max(cpu, 1e-9), float(free.mean())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ik", type=int, default=300, help="IK targets per robot and kind")
    ap.add_argument("--fk", type=int, default=5000, help="FK configurations per robot")
    ap.add_argument("--checks", type=int, default=3000, help="collision checks per robot and scene")
    ap.add_argument("--robots", default=",".join(ROBOTS), help="comma-separated: kuka,panda")
    args = ap.parse_args(argv)
    print(
        f"robwot_sim backend benchmark  python {platform.python_version()}  {platform.machine()}  "
        f"cpus={len(os.sched_getaffinity(0))}  load average {os.getloadavg()[0]:.1f}"
    )
    print(
        f"IK: {args.ik} seeded random reachable targets (success = within 1 mm and 1 deg, collision-free "
        f"requested); collision: {args.checks} random configurations per scene\n"
    )
    rows: list[list[str]] = []
    for name in args.robots.split(","):
        urdf = ROBOTS[name]
        with World() as w:
            rid = w.load_robot(urdf).id
            for kind, orient in (("position", False), ("pose", True)):
                rate, med, p99 = bench_ik(w, rid, args.ik, orient)
                rows.append(
                    [name, f"IK {kind}", f"{rate * 100:.1f}% ok", f"median {med:.3f} ms", f"p99 {p99:.3f} ms"]
                )
            fk_wall, fk_cpu = bench_fk(w, rid, args.fk)
            rows.append([name, "FK", f"{fk_wall:,.0f} configs/s wall", f"{fk_cpu:,.0f} configs/s CPU", ""])
        for k in SCENE_SIZES:
            wall, cpu, free = bench_collision(urdf, k, args.checks)
            rows.append(
                [
                    name,
                    f"collision {k} obstacles",
                    f"{wall:,.0f} checks/s wall",
                    f"{cpu:,.0f} checks/s CPU",
                    f"{free * 100:.0f}% free",
                ]
            )
        sys.stdout.flush()
    widths = [max(len(r[i]) for r in rows) for i in range(5)]
    header = ["robot", "measure", "result", "", ""]
    print("  ".join(h.ljust(wd) for h, wd in zip(header, widths, strict=True)).rstrip())
    print("  ".join("-" * wd for wd in widths))
    for r in rows:
        print("  ".join(c.ljust(wd) for c, wd in zip(r, widths, strict=True)).rstrip())
    return 0


if __name__ == "__main__":
    sys.exit(main())
