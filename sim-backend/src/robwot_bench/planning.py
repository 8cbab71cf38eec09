"""Planning times in one process: ``python -m robwot_bench.planning`` (``npm run bench:planning``).

The backend's verdicts (``sim/planner.py``, what ``robot.plan`` / ``validate*`` and every move run), without
the servient and the socket in between:

- a Cartesian target with a straight collision-free path from home (``plan_pose``): targets reached by
  collision-free configurations, those whose plan is straight timed (p50 / p95);
- detours: joint targets whose straight path from home collides, planned there (``plan_joints``: the
  straight check, then RRT-Connect) and back home again (p50 / p95 / max, refused plans counted); on the
  KUKA behind the wall of ``tests/test_server_motion.py``'s scene and on the Z1 and xArm7 of
  example-robot-data among the boxes of ``tests/test_sim_detour_symmetry.py``, from a home within the
  robot's clearance of a box. Prints the load average.

As a servient has them (``planning.warmUp``), the outer bounds' compiled kernels and TOPP-RA (which times
a detour's curve) are loaded before the first robot (waited for); ``--bullet`` leaves the kernels out,
every state checked by Bullet alone.
"""

from __future__ import annotations

import argparse
import os
import time
from collections.abc import Callable

import numpy as np

from robwot_bench.reference import example_robot
from robwot_sim.sim.kernels import kernels_ready
from robwot_sim.sim.planner import plan_joints, plan_pose
from robwot_sim.sim.world import World

DT = 1 / 60
BOXES = [("table", [1.4, 1.4, 0.02], [0.0, 0.0, -0.03]), ("pillar", [0.08, 0.08, 0.6], [0.35, 0.0, 0.3]),
         ("wall", [0.3, 0.05, 0.3], [0.0, 0.35, 0.3])]


def _kuka(world: World) -> tuple[str, np.ndarray]:
    world.load_robot("kuka_iiwa/model.urdf", robot_id="r")
    # where the end effector passes at joint 2 = 0.6 rad (test_server_motion.py's wall)
    where = list(world.fk("r", [0, 0.6, 0, 0, 0, 0, 0]).position)
    world.add_obstacle({"name": "wall", "shape": {"type": "box", "size": [0.1, 0.4, 0.1]}, "position": where})
    return "r", np.zeros(7)


def _arm(name: str) -> Callable[[World], tuple[str, np.ndarray]]:
    def load(world: World) -> tuple[str, np.ndarray]:
        r = example_robot(name)
        model = world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, robot_id="r")
        for box, size, pos in BOXES:
            world.add_obstacle({"name": box, "shape": {"type": "box", "size": size}, "position": pos})
        lo, hi = model.limits()
        rng = np.random.default_rng(1)
        while True:  # a home within the clearance of a box, not touching it
            home = rng.uniform(lo, hi) * 0.5
            world.set_joint_positions("r", home)
            if world.check_collision("r").collision_free and world.motion_clearance("r") == 0.0:
                return "r", home
    return load


ROBOTS = {"kuka": _kuka, "z1": _arm("z1"), "xarm7": _arm("xarm7")}


def _pct(xs: list[float]) -> str:
    if not xs:
        return "-"
    a = 1e3 * np.asarray(xs)
    return f"{np.percentile(a, 50):7.1f} {np.percentile(a, 95):7.1f} {a.max():7.1f}"


def measure(name: str, targets: int, seed: int) -> tuple[list[float], list[float], list[float], int, int]:
    """Straight validation times, detour times there and back (s), refusals there and back."""
    with World() as world:
        rid, home = ROBOTS[name](world)
        for bounds in world.warm_bounds():  # as a servient's planning.warmUp does (nothing with --bullet)
            bounds.fill_tables()
        lo, hi = world.robot_model(rid).limits()
        rng = np.random.default_rng(seed)
        straight: list[float] = []
        tries = 0
        while len(straight) < targets and tries < 20 * targets:
            tries += 1
            q = rng.uniform(lo, hi)
            if not world.check_collision(rid, q).collision_free:
                continue
            world.set_joint_positions(rid, home)
            t0 = time.perf_counter()
            plan = plan_pose(world, rid, world.fk(rid, q).position, None, 1.0, DT)
            if plan.valid and plan.checks["path"]["planned"] == "straight":
                straight.append(time.perf_counter() - t0)
        there: list[float] = []
        back: list[float] = []
        refused = [0, 0]
        tries = 0
        while len(there) < targets and tries < 50 * targets:
            tries += 1
            q = rng.uniform(lo, hi)
            if (not world.check_collision(rid, q).collision_free
                    or world.check_path(rid, q, start=home).collision_free):
                continue
            world.set_joint_positions(rid, home)
            t0 = time.perf_counter()
            plan = plan_joints(world, rid, q.tolist(), 1.0, DT)
            there.append(time.perf_counter() - t0)
            if not plan.valid or plan.target is None:
                refused[0] += 1
                continue
            world.set_joint_positions(rid, np.array(plan.target))
            t0 = time.perf_counter()
            returned = plan_joints(world, rid, home.tolist(), 1.0, DT)
            back.append(time.perf_counter() - t0)
            refused[1] += not returned.valid
    return straight, there, back, refused[0], refused[1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--robots", default=",".join(ROBOTS))
    p.add_argument("--targets", type=int, default=20)
    p.add_argument("--seed", type=int, default=26)
    p.add_argument("--bullet", action="store_true", help="without the outer bounds (Bullet alone)")
    args = p.parse_args()
    if args.bullet:
        os.environ["ROBWOT_OUTER_BOUNDS"] = "off"
    elif not kernels_ready(timeout=900.0):
        raise SystemExit("the outer bounds' kernels did not load (run with --bullet to measure without)")
    import toppra.algorithm  # what planning.warmUp's motion.load_timing imports, here waited for
    import toppra.constraint  # noqa: F401
    what = "Bullet alone" if args.bullet else "outer bounds loaded"
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"bench-planning ({what}): load average {load}", flush=True)
    print(f"{'robot':7s} {'what':22s} {'n':>4s} {'p50 ms':>7s} {'p95 ms':>7s} {'max ms':>7s} {'refused':>7s}")
    for name in args.robots.split(","):
        straight, there, back, no_there, no_back = measure(name, args.targets, args.seed)
        print(f"{name:7s} {'validate (straight)':22s} {len(straight):4d} {_pct(straight)} {'':>7s}")
        print(f"{name:7s} {'detour from home':22s} {len(there):4d} {_pct(there)} {no_there:7d}")
        print(f"{name:7s} {'back home':22s} {len(back):4d} {_pct(back)} {no_back:7d}", flush=True)
    print("load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
