"""Fidelity benchmark: ``python -m robwot_bench.fidelity`` (``npm run bench:fidelity``).

The twin's collision labels (``World.collision_free_batch``, the path workspace generation uses) against
the exact-mesh reference (``robwot_bench.reference``: Pinocchio + Coal) on seeded uniform random
configurations of UR10, UR5 and Panda as published in example-robot-data (mesh collision geometry) and
the bundled KUKA iiwa. Prints a table: false accepts (the twin says free, the reference colliding) and
false rejects (the twin says colliding, the reference free, as a share of the reference-free ones); the
verdicts on reachable Cartesian targets; and grazing plates (`graze_trials`): thin boxes placed so that
a move only grazes them, by bisection against a fine reference sweep, at several speeds and thicknesses
— how many the twin would execute (must be 0) and how many checking only the planned states would.
Needs the ``reference`` extra (installed with the dev tools by ``npm install``).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np

from robwot_bench.reference import ExactReference, example_robot
from robwot_sim.model.urdf import pybullet_data_path
from robwot_sim.sim.planner import plan_pose
from robwot_sim.sim.world import World


def measure(name: str, samples: int, seed: int, with_srdf: bool = False) -> dict[str, float | int | str]:
    """One row: label agreement of the twin with the reference for one robot (both with its SRDF or not)."""
    if name == "kuka":
        urdf, srdf, roots = pybullet_data_path() / "kuka_iiwa/model.urdf", None, {}
    else:
        r = example_robot(name)
        urdf, srdf, roots = r.urdf, r.srdf, r.package_roots
    srdf = srdf if with_srdf else None
    with World() as world:
        model = world.load_robot(str(urdf), package_roots=roots, srdf=srdf)
        lo, hi = model.limits()
        qs = np.random.default_rng(seed).uniform(lo, hi, size=(samples, len(lo)))
        t0 = time.perf_counter()
        ours = world.collision_free_batch(model.id, qs)
        ours_s = time.perf_counter() - t0
    ref = ExactReference(urdf, roots, model.controllable, srdf)
    truth = ref.collision_free(qs)
    free = int(truth.sum())
    false_reject = int(np.sum(~ours & truth))
    return {"robot": name, "srdf": "yes" if srdf else "no", "samples": samples, "ref_free": free,
            "ours_free": int(ours.sum()),
            "false_accept": int(np.sum(ours & ~truth)), "false_reject": false_reject,
            "false_reject_pct": 100.0 * false_reject / max(1, free), "ms_per_config": 1e3 * ours_s / samples,
            "srdf_file": str(srdf) if srdf else ""}


def verdicts(name: str, targets: int, seed: int) -> dict[str, float | int | str]:
    """The twin's verdict on Cartesian targets reached by reference-free configurations (its SRDF loaded):
    the backend's plan from the home pose (`sim/planner.py`, what `robot.plan` and every move run: IK within
    1 mm, collision-free, other IK solutions when a path collides, the checked path). Every target is
    reachable, so every refusal is a false reject; `alternative` counts targets reached through another
    IK solution than the first."""
    r = example_robot(name)
    with World() as world:
        model = world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf)
        ref = ExactReference(r.urdf, r.package_roots, model.controllable, r.srdf)
        lo, hi = model.limits()
        home = world.get_joint_positions(model.id)
        rng = np.random.default_rng(seed)
        accepted = tried = alternative = reached = 0
        while tried < targets:
            q = rng.uniform(lo, hi)
            if not ref.collision_free(q[None, :])[0]:
                continue
            tried += 1
            world.set_joint_positions(model.id, home)
            plan = plan_pose(world, model.id, world.fk(model.id, q).position, None, 1.0, 1.0 / 240.0)
            if plan.valid and plan.target is not None:
                accepted += 1
                alternative += plan.checks["ik"]["solutions"] > 1
                goal = world.fk(model.id, q).position
                end = world.fk(model.id, plan.target).position
                reached += float(np.linalg.norm(np.subtract(end, goal))) <= 1e-3
    return {"robot": name, "targets": targets, "accepted": accepted, "alternative": alternative,
            "reached_pct": 100.0 * reached / targets,
            "false_reject_pct": 100.0 * (targets - accepted) / targets}


#: states of the reference sweep a graze is measured against
FINE = 1500


def _touches(world: World, rid: str, path: np.ndarray) -> bool:
    """Reference: the straight joint path sampled FINE times, contact at distance <= 0."""
    dense = path[0] + np.linspace(0, 1, FINE)[:, None] * (path[-1] - path[0])
    return not bool(np.all(world.collision_free_batch(rid, dense)))


@dataclass
class Grazes:
    """Outcome of `graze_trials`: plates grazed, refused by the twin's path check, and let through by a
    check of the planned states alone (one per 1/240 s at the given speed, what the twin did first)."""

    grazes: int = 0
    refused: int = 0
    planned_states_missed: int = 0


def graze_trials(world: World, rid: str, rng: np.random.Generator, count: int, thickness: float = 0.005,
                 speed: float = 1.0) -> Grazes:
    """``count`` grazing plates for random free moves of robot ``rid`` (joint speed ``speed`` as a share of
    the limits): a ``thickness`` m plate across a moving link half-way along the move, pushed out along a
    random normal by bisection (8 steps, ~1.6 mm) until the reference sweep only just touches it."""
    e = world.scene.entry(rid)
    lo, hi = world.robot_model(rid).limits()
    out = Grazes()
    while out.grazes < count:
        start, goal = rng.uniform(lo * 0.8, hi * 0.8), rng.uniform(lo * 0.8, hi * 0.8)
        world.set_joint_positions(rid, start)
        if not world.check_path(rid, goal).collision_free:
            continue  # the arm hits itself on this path: not a plate case
        path = world.plan_motion(rid, goal, speed=speed).rows()  # a move's states: a few hundred
        e.bound.apply(path[0] + rng.uniform(0.3, 0.7) * (path[-1] - path[0]))
        link = int(rng.choice(e.bound.moving_links[len(e.bound.moving_links) // 3:]))
        center = np.array(world.scene.bullet.link_frame(e.bound.body, link)[0])
        e.bound.apply(start)
        normal = rng.normal(size=3)
        normal /= np.linalg.norm(normal)
        z = np.array([0.0, 0.0, 1.0])
        axis = np.cross(z, normal)
        angle = np.arccos(np.clip(normal @ z, -1, 1))
        quat = [*(np.sin(angle / 2) * axis / (np.linalg.norm(axis) or 1)), np.cos(angle / 2)]

        def plate(at: float, center: np.ndarray = center, normal: np.ndarray = normal,
                  quat: list[float] = quat) -> None:
            world.add_obstacle({"name": "plate", "shape": {"type": "box", "size": [0.15, 0.15, thickness]},
                                "position": (center + at * normal).tolist(), "orientation": quat})

        inside, outside = 0.0, 0.4
        plate(outside)
        far_free = not _touches(world, rid, path)
        world.remove_obstacle("plate")
        if not far_free:
            continue
        for _ in range(8):
            s = (inside + outside) / 2
            plate(s)
            hit = _touches(world, rid, path)
            world.remove_obstacle("plate")
            inside, outside = (s, outside) if hit else (inside, s)
        plate(inside)  # touched by the fine sweep, <= ~2 mm deep
        ends_free = all(world.check_collision(rid, q).collision_free for q in (start, goal))
        if ends_free and _touches(world, rid, path):
            out.grazes += 1
            out.refused += not world.check_path(rid, goal, speed=speed).collision_free
            out.planned_states_missed += bool(np.all(world.collision_free_batch(rid, path)))
        world.remove_obstacle("plate")
    return out


def grazes(name: str, count: int, seed: int) -> list[dict[str, float | int | str]]:
    """Per speed and plate thickness: grazes, executed by the twin (never), missed by planned states."""
    rows: list[dict[str, float | int | str]] = []
    for speed in (0.25, 1.0):
        for thickness in (0.005, 0.02):
            with World() as world:
                if name == "kuka":
                    model = world.load_robot(str(pybullet_data_path() / "kuka_iiwa/model.urdf"))
                else:
                    r = example_robot(name)
                    model = world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf)
                g = graze_trials(world, model.id, np.random.default_rng([seed, int(speed * 100)]), count,
                                 thickness, speed)
            rows.append({"robot": name, "speed": speed, "thickness": thickness, "grazes": g.grazes,
                         "executed": g.grazes - g.refused, "planned_missed": g.planned_states_missed})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=20_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--robots", default="ur10,ur5,panda,kuka")
    ap.add_argument("--targets", type=int, default=200, help="reachable Cartesian targets per robot")
    ap.add_argument("--grazes", type=int, default=10, help="grazing plates per robot, speed and thickness")
    args = ap.parse_args()
    print(f"labels vs exact-mesh reference (Pinocchio + Coal), {args.samples} uniform random configurations, "
          f"seed {args.seed}, self-collision, adjacent links excluded on both sides")
    head = (f"{'robot':<7}{'srdf':>5}{'ref free':>10}{'twin free':>11}{'false accept':>14}"
            f"{'false reject':>14}{'% of free':>11}{'ms/config':>11}")
    print(head)
    print("-" * len(head))
    rows = [(name, False) for name in args.robots.split(",")]
    rows += [(name, True) for name in args.robots.split(",")  # those published with an SRDF
             if name != "kuka" and example_robot(name).srdf is not None]
    for name, with_srdf in rows:
        r = measure(name, args.samples, args.seed, with_srdf)
        print(f"{r['robot']:<7}{r['srdf']:>5}{r['ref_free']:>10}{r['ours_free']:>11}{r['false_accept']:>14}"
              f"{r['false_reject']:>14}{r['false_reject_pct']:>10.1f}%{r['ms_per_config']:>11.3f}")

    if args.targets > 0:
        print(f"\nverdicts on {args.targets} reachable targets (reference-free configurations, SRDF where "
              "published), position only, from the home pose")
        print(f"{'robot':<7}{'accepted':>10}{'false reject':>14}{'other IK':>10}{'reached ≤ 1 mm':>16}")
    for name in ("ur10", "panda"):
        if name in args.robots.split(",") and args.targets > 0:
            v = verdicts(name, args.targets, args.seed)
            print(f"{v['robot']:<7}{v['accepted']:>10}{v['false_reject_pct']:>13.1f}%{v['alternative']:>10}"
                  f"{v['reached_pct']:>15.1f}%")

    print(f"\ngrazing plates ({args.grazes} per row; SRDF where published): moves that only graze a plate")
    print(f"{'robot':<7}{'speed':>7}{'plate mm':>10}{'grazes':>8}{'executed':>10}{'planned states only':>21}")
    for name in args.robots.split(","):
        for g in grazes(name, args.grazes, args.seed):
            print(f"{g['robot']:<7}{g['speed']:>7.2f}{1000 * float(g['thickness']):>10.0f}{g['grazes']:>8}"
                  f"{g['executed']:>10}{g['planned_missed']:>21}")


if __name__ == "__main__":
    main()
