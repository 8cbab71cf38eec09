"""Panda planning problems like MotionBenchMaker's: ``python -m robwot_bench.mbm`` (``npm run bench:mbm``).

MotionBenchMaker (Chamzas et al., RA-L 2021) poses a Panda start and goal configuration among shelves,
boxes, cages and tables, 100 problems per scene kind. Its problem files are not used here: the problems are
made by this script, seeded, in four kinds of the same nature (``KINDS``), each scene a set of boxes laid
out with random size, distance and heading:

- ``shelf``: a bookshelf (sides, back, boards) facing the robot; the goal reaches into a shelf cell,
  the hand level and pointing in;
- ``box``: an open box on the table in front; the goal reaches into it from above;
- ``cage``: a cube of bars on a lower table in front; the goal reaches into it from above;
- ``table_under``: a table top over the robot's front; the goal reaches under it.

The start is the Panda's ready pose; a goal is an IK solution (collision-free, by our check) for a pose in
the scene's cavity; a scene whose goal IK cannot reach is drawn again (counted). After a warm-up (the
compiled kernels of the outer bounds loaded, one plan made: what a running servient has done), each problem is
planned as a move is (``plan_joints``: the straight check, else RRT-Connect, smoothing, timing, the
timed path checked again state by state) and timed: the time to a checked path. Every state of each path
found, with steps of at most ``STEP`` rad between them, is then checked on the exact meshes
(``ExactReference``: Coal through Pinocchio, the boxes as boxes): a path with a state in contact there is
a false accept. The reference is first shown a known positive (the goal state moved into a board or wall).

Prints per kind and overall the problems solved, the straight ones, the median / p95 / max time, the
exact check, and VAMP's published figures beside ours with both machines named.
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import platform
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from robwot_bench.reference import ExactReference, example_robot
from robwot_sim.errors import Unreachable
from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.sim.kernels import kernels_ready
from robwot_sim.sim.planner import plan_joints
from robwot_sim.sim.world import World

DT = 1 / 60
#: rad: the largest joint step between two states the exact check looks at
STEP = 0.005
READY = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785, 0.02]
#: (size, centre, quaternion xyzw) of a box, robot base frame (the base stands on z = 0)
Box = tuple[list[float], list[float], list[float]]
#: published figures of VAMP's RRT-Connect on MotionBenchMaker's Panda problems (700: seven scene kinds
#: of 100), from KavrakiLab/vamp's scripts/README.md (``evaluate_mbm.py``), one core of an AMD Ryzen 9 7950X
VAMP = {"machine": "AMD Ryzen 9 7950X, one core (KavrakiLab/vamp scripts/README.md, evaluate_mbm.py)",
        "planning_us": (35.0, 343.3), "with_simplification_us": (99.0, 441.6)}


@dataclass(frozen=True)
class Problem:
    kind: str
    boxes: list[Box]
    goal: list[float]
    redrawn: int


def _turned(yaw: float, x: float, y: float) -> tuple[float, float]:
    return math.cos(yaw) * x - math.sin(yaw) * y, math.sin(yaw) * x + math.cos(yaw) * y


def _frame(yaw: float, reach: float) -> Callable[[list[float], list[float]], Box]:
    """Boxes given in a frame at ``reach`` m along heading ``yaw`` (x pointing away from the robot)."""
    quat = list(quat_from_rpy([0.0, 0.0, yaw]))

    def box(size: list[float], at: list[float]) -> Box:
        x, y = _turned(yaw, reach + at[0], at[1])
        return size, [x, y, at[2]], quat
    return box


def _shelf(rng: np.random.Generator) -> tuple[list[Box], list[float], list[float]]:
    yaw, reach = rng.uniform(-0.6, 0.6), rng.uniform(0.55, 0.75)
    width, depth, boards = rng.uniform(0.6, 0.9), rng.uniform(0.25, 0.35), [0.1, 0.4, 0.7, 1.0]
    box = _frame(yaw, reach)
    t = 0.02
    out = [box([depth, t, 1.1], [depth / 2, side * width / 2, 0.55]) for side in (-1, 1)]
    out.append(box([t, width, 1.1], [depth, 0.0, 0.55]))
    out += [box([depth, width, t], [depth / 2, 0.0, z]) for z in boards]
    level = int(rng.integers(1, 3))
    z = (boards[level] + boards[level + 1]) / 2
    x, y = _turned(yaw, reach + rng.uniform(0.08, 0.14), rng.uniform(-width / 4, width / 4))
    # the hand's z axis (the fingers' direction) pointing into the shelf, level
    return out, [x, y, z], list(quat_from_rpy([0.0, math.pi / 2, yaw]))


def _box(rng: np.random.Generator) -> tuple[list[Box], list[float], list[float]]:
    yaw, reach = rng.uniform(-1.0, 1.0), rng.uniform(0.45, 0.6)
    side, height, t = rng.uniform(0.25, 0.35), rng.uniform(0.15, 0.25), 0.02
    box = _frame(yaw, reach)
    out = [box([side, side, t], [0.0, 0.0, t / 2])]
    out += [box([t, side, height], [s * side / 2, 0.0, height / 2]) for s in (-1, 1)]
    out += [box([side, t, height], [0.0, s * side / 2, height / 2]) for s in (-1, 1)]
    x, y = _turned(yaw, reach + rng.uniform(-0.04, 0.04), rng.uniform(-0.04, 0.04))
    down = list(quat_from_rpy([math.pi, 0.0, rng.uniform(-math.pi, math.pi)]))  # the hand pointing down
    return out, [x, y, t + 0.13 + rng.uniform(0.0, 0.05)], down


def _cage(rng: np.random.Generator) -> tuple[list[Box], list[float], list[float]]:
    yaw, reach = rng.uniform(-1.0, 1.0), rng.uniform(0.55, 0.65)
    side, base, t = rng.uniform(0.3, 0.4), rng.uniform(-0.15, -0.05), 0.02  # on a lower table
    box = _frame(yaw, reach)
    h = side / 2
    out = [box([t, t, side], [sx * h, sy * h, base + h]) for sx in (-1, 1) for sy in (-1, 1)]
    for z in (base, base + side):  # the bottom and top rings
        out += [box([side, t, t], [0.0, sy * h, z]) for sy in (-1, 1)]
        out += [box([t, side, t], [sx * h, 0.0, z]) for sx in (-1, 1)]
    out.append(box([side, side, t], [0.0, 0.0, base - t]))  # the floor it stands on
    x, y = _turned(yaw, reach, 0.0)
    # the hand pointing down, its fingers' spread along one side of the cage
    return out, [x, y, base + h * 1.8], list(quat_from_rpy([math.pi, 0.0, yaw + rng.uniform(-0.3, 0.3)]))


def _table_under(rng: np.random.Generator) -> tuple[list[Box], list[float], list[float]]:
    yaw, height = rng.uniform(-0.8, 0.8), rng.uniform(0.4, 0.5)
    box = _frame(yaw, 0.3)
    out = [box([0.7, 1.0, 0.03], [0.35, 0.0, height])]
    out += [box([0.04, 0.04, height], [x, y, height / 2]) for x in (0.05, 0.65) for y in (-0.46, 0.46)]
    x, y = _turned(yaw, 0.3 + rng.uniform(0.15, 0.3), rng.uniform(-0.2, 0.2))
    return out, [x, y, rng.uniform(0.12, height - 0.15)], list(quat_from_rpy([0.0, math.pi / 2, yaw]))


KINDS: dict[str, Callable[[np.random.Generator], tuple[list[Box], list[float], list[float]]]] = {
    "shelf": _shelf, "box": _box, "cage": _cage, "table_under": _table_under}


def _load(world: World) -> None:
    r = example_robot("panda")
    world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, robot_id="panda")


def _scene(world: World, boxes: Sequence[Box]) -> None:
    """The problem's boxes as the world's obstacles (the last problem's removed)."""
    for ob in world.list()["obstacles"]:
        world.remove_obstacle(ob["name"])
    for i, (size, centre, quat) in enumerate(boxes):
        world.add_obstacle({"name": f"b{i}", "shape": {"type": "box", "size": size}, "position": centre,
                            "orientation": quat})


def problems(world: World, per_kind: int, seed: int) -> list[Problem]:
    """``per_kind`` problems of each kind, seeded; a scene whose goal pose has no collision-free IK
    solution (or whose ready pose collides) is drawn again."""
    rng = np.random.default_rng(seed)
    out = []
    for kind, make in KINDS.items():
        made = redrawn = 0
        while made < per_kind:
            boxes, position, quat = make(rng)
            _scene(world, boxes)
            if not world.check_collision("panda", READY).collision_free:
                redrawn += 1
                continue
            try:
                ik = world.ik("panda", position, quat, seed=READY)
            except Unreachable:
                ik = None
            if ik is None or not ik.collision_free:
                redrawn += 1
                continue
            out.append(Problem(kind, boxes, [*ik.positions[:7], READY[7]], redrawn))
            made += 1
            redrawn = 0
    return out


def _dense(states: np.ndarray) -> np.ndarray:
    """The states with linear steps inserted so no joint moves more than ``STEP`` between two."""
    out = [states[:1]]
    for a, b in itertools.pairwise(states):
        n = max(1, math.ceil(float(np.abs(b - a).max()) / STEP))
        out.append(a + (b - a) * (np.arange(1, n + 1)[:, None] / n))
    return np.concatenate(out)


@dataclass
class Outcome:
    kind: str
    solved: bool
    straight: bool
    seconds: float
    states: int = 0
    exact_contact: bool = False


def solve(world: World, p: Problem, reference: Callable[[Sequence[Box]], ExactReference]) -> Outcome:
    _scene(world, p.boxes)
    world.set_joint_positions("panda", np.array(READY))
    t0 = time.perf_counter()
    plan = plan_joints(world, "panda", p.goal, 1.0, DT)
    seconds = time.perf_counter() - t0
    if not plan.valid or plan.path is None:
        return Outcome(p.kind, False, False, seconds)
    states = _dense(plan.path.rows())
    free = reference(p.boxes).collision_free(states)
    straight = plan.checks.get("path", {}).get("planned") == "straight"
    return Outcome(p.kind, True, straight, seconds, len(states), not bool(free.all()))


def _reference_for(controllable: Sequence[str]) -> Callable[[Sequence[Box]], ExactReference]:
    r = example_robot("panda")
    return lambda boxes: ExactReference(r.urdf, r.package_roots, controllable, r.srdf, obstacles=boxes,
                                          mimic=True)


def _known_positive(world: World, p: Problem, reference: Callable[[Sequence[Box]], ExactReference]) -> bool:
    """The exact reference calls a configuration colliding whose hand is moved onto a board or wall: the
    goal with its first joint turned until our own check says it collides, then 0.05 rad more."""
    _scene(world, p.boxes)
    q = np.array(p.goal)
    for turn in np.linspace(0.0, math.pi, 181):
        q2 = q.copy()
        q2[0] = np.clip(q[0] + turn, -2.89, 2.89)
        if not world.check_collision("panda", q2).collision_free:
            q2[0] = np.clip(q2[0] + 0.05, -2.89, 2.89)
            return not bool(reference(p.boxes).collision_free(q2[None])[0])
    return False


def _cpu() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return f"{line.split(':', 1)[1].strip()}, {os.cpu_count()} cores"
    except OSError:
        pass
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores"


def _row(name: str, rows: list[Outcome]) -> str:
    solved = [o for o in rows if o.solved]
    t = 1e3 * np.array([o.seconds for o in solved]) if solved else np.array([math.nan])
    contact = sum(o.exact_contact for o in solved)
    return (f"| {name} | {len(rows)} | {len(solved)} | {sum(o.straight for o in solved)} | "
            f"{np.median(t):.1f} | {np.percentile(t, 95):.1f} | {t.max():.1f} | "
            f"{sum(o.states for o in solved)} | {contact} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--per-kind", type=int, default=25, help="problems of each of the 4 kinds (default 25)")
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args()
    print(f"bench-mbm: {_cpu()}; load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()), flush=True)
    with World() as world:
        _load(world)
        made = problems(world, args.per_kind, args.seed)
        if not kernels_ready(timeout=300.0):
            print("the outer bounds' kernels did not load: every state is checked by Bullet alone")
        _scene(world, made[-1].boxes)  # the warm-up plan (its imports, the bounds of a robot), not timed
        world.set_joint_positions("panda", np.array(READY))
        plan_joints(world, "panda", made[-1].goal, 1.0, DT)
        for bounds in world.warm_bounds():  # self pair tables filled, as a servient's planning.warmUp does
            bounds.fill_tables()
        reference = _reference_for(world.robot_model("panda").controllable)
        if not _known_positive(world, made[0], reference):
            raise SystemExit("the exact reference missed a known contact: its verdicts prove nothing")
        outcomes = [solve(world, problem, reference) for problem in made]
    print(f"{len(made)} problems ({sum(m.redrawn for m in made)} scenes drawn again: no collision-free goal)")
    print("| kind | problems | solved | straight | median ms | p95 ms | max ms | states checked exactly |"
          " paths in contact (exact) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for kind in KINDS:
        print(_row(kind, [o for o in outcomes if o.kind == kind]))
    print(_row("all", outcomes))
    plan50, plan95 = VAMP["planning_us"]
    simple50, simple95 = VAMP["with_simplification_us"]
    print(f"VAMP, published ({VAMP['machine']}): planning median {plan50:.0f} us, p95 {plan95:.0f} us; "
          f"with simplification median {simple50:.0f} us, p95 {simple95:.0f} us (MotionBenchMaker's own "
          "700 Panda problems, a robot compiled ahead of time)")
    print("load average " + " ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
