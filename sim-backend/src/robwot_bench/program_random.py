"""Random programs: ``python -m robwot_bench.program_random`` (second table of ``npm run bench:program``).

Two arms of example-robot-data the project does not bundle, xArm7 and UR5, each loaded by a real backend
(``python -m robwot_sim serve``, over the WebSocket as ``program.py`` does) with a 12 cm box tool mounted by
``robot.attachTool`` (TCP 12 cm along the flange's z) and a table plus three boxes in reach as obstacles.
Per arm ``--programs`` seeded random programs (``--seed``; the same seed gives the same programs), each
``program.plan``-ed from its start configuration; the first ``--runs`` valid ones also ``program.run`` at
real time 1.

Programs. From a random collision-free start (Coal, exact meshes, >= 2 cm from everything, the TCP above
10 cm), 6-10 steps (``--steps``), each aiming at a random configuration near the previous one (normal,
0.35 rad for PTP, 0.2 rad for LIN / CIRC; >= 2 cm from everything, its straight joint path free by Coal),
reached as: PTP to joints; PTP to its pose (FK: position and orientation); LIN to its pose; CIRC to its
pose through the TCP point of the joint-space midpoint (moved 2 cm off the chord when nearly on it); and
once per program a PTP to a far configuration whose straight joint path collides (Coal, samples at most
0.02 rad apart), so the planner detours. Speeds and accelerations 0.3-1, TCP speeds 0.1-0.5 m/s, a blend
radius of 1-5 cm on a third of the steps (never the last). A refused step is recorded, then replaced by a
PTP to its target configuration (a refused PTP to joints is dropped, a pose / LIN / CIRC after it turned
into a PTP to its configuration, as its start moved; a second refused PTP at the same step ends the
program before it) and the program planned again, so every program
yields a valid plan to time (a start the backend calls colliding drops the program).

Time-optimal bound: ``program_bound.py`` (its docstring; none of the planner's timing code used), the TCP's
total acceleration relaxed to its components along 128 directions so that it stays a lower bound on time.
The table gives reported ``cycleTime`` / bound per program (max and median). Self-check ("pieces over"):
pieces whose bound exceeds the plan's own time for them (their samples times dt) by more than 1 % + one
sample; a plan within its limits is never faster than the time-optimal motion along its own path, so these
count where the bound (or the plan's limits) is wrong.

Refusals of LIN / CIRC steps: checked by an independent IK, ``program_kin.py`` (its docstring); a false
refusal is one it follows at the allowed joint speeds, free by Coal with the clearance kept.

Executed: ``program.run`` at real time 1, its ``wallTime`` / reported ``cycleTime`` (the worst of the runs)
and the 1-minute load average right after each run (the least of them given). ``--load N`` runs N niced
busy processes from before the first program is planned until the last has run (``program.busy_load``; the
issue's "within 2 % at load average >= 4"); ``npm run bench:program`` holds them itself and passes 0.
Rests and straight rests: ``program_bound.py``. ``program.plan`` round trip median also given.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import shutil
import statistics
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_bench import program_jerk
from robwot_bench.program import Backend, busy_load
from robwot_bench.program_bound import PIECES, Limits, bound, rests
from robwot_bench.program_kin import Follow, Kin, follow
from robwot_bench.reference import example_robot
from robwot_sim.limits import ACCELERATION_TIME, DEFAULT_CLEARANCE, DEFAULT_DT

F = npt.NDArray[np.float64]

ARMS = ("xarm7", "ur5")
TOOL_SIZE = (0.04, 0.04, 0.12)
TCP = (0.0, 0.0, 0.12, 0.0, 0.0, 0.0)
#: (name, size, position) in the world frame, the arms' bases at the origin
OBSTACLES = [
    ("table", (1.6, 1.6, 0.02), (0.0, 0.0, -0.03)),
    ("box_a", (0.12, 0.12, 0.25), (0.42, 0.18, 0.125)),
    ("box_b", (0.2, 0.08, 0.3), (-0.15, 0.45, 0.15)),
    ("box_c", (0.08, 0.08, 0.08), (0.3, -0.35, 0.45)),
]
START_MARGIN = 0.02


# --- programs -------------------------------------------------------------------------------------------


@dataclass
class Arm:
    name: str
    rid: str
    names: list[str]
    lo: F
    hi: F
    lim: Limits
    kin: Kin
    tmp: Path


@dataclass
class Gen:
    """A generated step, its target configuration (what a refused step is replaced by) and kind."""

    step: dict[str, Any]
    q: F
    kind: str


def load_arm(b: Backend, name: str, jerk_factor: float = 0.0) -> Arm:
    """The arm with its tool; with ``jerk_factor``, every joint jerk-limited at that many times its
    acceleration limit (robot.load ``jerkLimits``: the arm loaded once to learn its joints, then again)."""
    r = example_robot(name)
    att = b.call("robot.attachTool", {"urdf": str(r.urdf), "packageRoots": r.package_roots, "tcp": list(TCP),
                                      "shape": {"type": "box", "size": list(TOOL_SIZE)}})
    params: dict[str, Any] = {"urdf": att["urdf"], "packageRoots": att["packageRoots"],
                              "eeLink": att["tcpLink"], "id": name}
    if r.srdf is not None:
        params["srdf"] = str(r.srdf)
    model = b.call("robot.load", params)
    names = list(model["controllable"])
    joints = {j["name"]: j for j in model["joints"]}
    if jerk_factor > 0:
        b.call("robot.remove", {"robot": name})
        params["jerkLimits"] = {n: jerk_factor * joints[n]["velocity"] / ACCELERATION_TIME for n in names}
        b.call("robot.load", params)
    lo = np.array([joints[n]["lower"] for n in names], dtype=np.float64)
    hi = np.array([joints[n]["upper"] for n in names], dtype=np.float64)
    vmax = np.array([joints[n]["velocity"] for n in names], dtype=np.float64)
    kin = Kin(Path(att["urdf"]), dict(att["packageRoots"]), names, r.srdf,
              [(size, pos) for _, size, pos in OBSTACLES])
    lim = Limits(vmax, vmax / ACCELERATION_TIME)
    return Arm(name, name, names, lo, hi, lim, kin, Path(att["urdf"]).parent)


def generate(arm: Arm, rng: np.random.Generator, n_steps: int) -> tuple[F, list[Gen]]:
    """A start configuration and the program's steps (see the module docstring)."""
    lo = np.maximum(arm.lo, -math.pi) + 0.05
    hi = np.minimum(arm.hi, math.pi) - 0.05
    kin = arm.kin
    while True:
        q0 = rng.uniform(lo, hi)
        if kin.fk(q0)[0][2] > 0.1 and kin.clear(q0, START_MARGIN):
            break
    detour_at = int(rng.integers(0, n_steps))
    out: list[Gen] = []
    prev = q0
    for k in range(n_steps):
        kind = "detour" if k == detour_at else str(rng.choice(["joints", "pose", "lin", "circ"],
                                                               p=[0.3, 0.2, 0.3, 0.2]))
        q = _target(arm, rng, prev, kind, lo, hi)
        if q is None and kind == "detour":
            kind = "joints"
            q = _target(arm, rng, prev, kind, lo, hi)
        if q is None:
            continue
        step: dict[str, Any] = {"speed": round(float(rng.uniform(0.3, 1.0)), 3),
                                "acceleration": round(float(rng.uniform(0.3, 1.0)), 3)}
        p, rot = kin.fk(q)
        if kind in ("joints", "detour"):
            step["target"] = [float(v) for v in q]
        else:
            step["position"] = [float(v) for v in p]
            step["orientation"] = kin.quat(rot)
        if kind in ("lin", "circ"):
            step["motion"] = kind
            step["tcpSpeed"] = round(float(rng.uniform(0.1, 0.5)), 3)
        if kind == "circ":
            a = kin.fk(prev)[0]
            via = kin.fk((prev + q) / 2)[0]
            chord = p - a
            off = via - a - chord * float((via - a) @ chord) / max(1e-12, float(chord @ chord))
            if np.linalg.norm(off) < 0.01:
                perp = np.cross(chord, [0.0, 0.0, 1.0])
                if np.linalg.norm(perp) < 1e-9:
                    perp = np.array([1.0, 0.0, 0.0])
                via = via + 0.02 * perp / np.linalg.norm(perp)
            step["via"] = [float(v) for v in via]
        if k < n_steps - 1 and rng.random() < 1 / 3:
            step["blend"] = round(float(rng.uniform(0.01, 0.05)), 3)
        out.append(Gen(step, q, kind))
        prev = q
    if out:
        out[-1].step.pop("blend", None)
    return q0, out


def _target(arm: Arm, rng: np.random.Generator, prev: F, kind: str, lo: F, hi: F) -> F | None:
    kin = arm.kin
    for _ in range(60):
        if kind == "detour":
            q = rng.uniform(lo, hi)
        else:
            q = np.clip(prev + rng.normal(0.0, 0.2 if kind in ("lin", "circ") else 0.35, len(prev)), lo, hi)
        p = kin.fk(q)[0]
        if p[2] < 0.05 or not kin.clear(q, START_MARGIN):
            continue
        if kind in ("lin", "circ") and np.linalg.norm(p - kin.fk(prev)[0]) < 0.03:
            continue
        free = kin.path_free(prev, q)
        if kind == "detour" and free:
            continue
        if kind != "detour" and not free:
            continue
        return q
    return None


# --- running --------------------------------------------------------------------------------------------


@dataclass
class Refusal:
    program: int
    step: int
    kind: str
    reason: str
    check: Follow | None = None


@dataclass
class ArmResult:
    name: str
    programs: int = 0
    valid: int = 0
    steps: int = 0
    ratios: list[float] = field(default_factory=list)
    rows: list[tuple[int, int, float, float]] = field(default_factory=list)
    refusals: list[Refusal] = field(default_factory=list)
    runs: list[tuple[float, float, float]] = field(default_factory=list)  # (wall, reported, load)
    rests: int = 0
    straight_rests: int = 0
    detours: int = 0
    plan_ms: list[float] = field(default_factory=list)
    bound_failures: int = 0
    #: pieces whose bound exceeds the plan's own time for them by more than 1 % + one sample (the bound's
    #: self-check: a plan within its limits is never faster than the time-optimal on its own path)
    over: int = 0
    pieces: int = 0
    #: the valid programs: start, steps, cycle time (planned again with jerk limits: ``program_jerk.py``)
    kept: list[tuple[F, list[dict[str, Any]], float]] = field(default_factory=list)


def run_arm(name: str, programs: int, n_steps: tuple[int, int], runs: int, seed: int,
            log: Callable[[str], None]) -> ArmResult:
    """One backend with the arm, its tool and the obstacles; the programs planned (and some run)."""
    b = Backend()
    res = ArmResult(name)
    arm: Arm | None = None
    try:
        arm = load_arm(b, name)
        for obs, size, pos in OBSTACLES:
            b.call("obstacle.add", {"name": obs, "shape": {"type": "box", "size": list(size)},
                                    "position": list(pos)})
        for i in range(programs):
            rng = np.random.default_rng([seed, ARMS.index(name), i])
            q0, gens = generate(arm, rng, int(rng.integers(n_steps[0], n_steps[1] + 1)))
            res.programs += 1
            plan, steps = _plan_valid(b, arm, q0, gens, i, res)
            if plan is None or not steps:
                log(f"{name} program {i}: nothing valid left")
                continue
            res.valid += 1
            res.kept.append((q0, steps, float(plan["cycleTime"])))
            res.steps += len(steps)
            res.detours += sum(1 for s in plan["steps"] if s.get("planned") == "detour")
            cycle = float(plan["cycleTime"])
            try:
                opt = bound(plan, steps, arm.lim, arm.kin)
            except RuntimeError as err:  # TOPP-RA on a badly conditioned piece: counted, not hidden
                res.bound_failures += 1
                log(f"{name} program {i}: no bound ({err})")
                continue
            dt = float(plan["trajectory"]["dt"])
            res.pieces += len(PIECES)
            res.over += sum(1 for *_, t, own_t, _ in PIECES if t > 1.01 * own_t + dt)
            res.ratios.append(cycle / opt)
            res.rows.append((i, len(steps), cycle, opt))
            found, straight = rests(plan, steps)
            res.rests += found
            res.straight_rests += straight
            log(f"{name} program {i}: {len(steps)} steps, cycle {cycle:.3f} s, bound {opt:.3f} s, "
                f"ratio {cycle / opt:.3f}, rests {found} (straight {straight})")
            if len(res.runs) < runs:
                b.call("robot.setJointPositions", {"robot": arm.rid, "positions": [float(v) for v in q0]})
                try:
                    run = b.call("program.run", {"robot": arm.rid, "steps": steps, "realtime": 1})
                except RuntimeError as err:  # planned again: a detour may not be found this time
                    log(f"{name} program {i}: run refused ({str(err)[:200]})")
                    continue
                load = os.getloadavg()[0]
                if run["status"] == "reached":
                    res.runs.append((float(run["wallTime"]), float(run["program"]["cycleTime"]), load))
                else:
                    log(f"{name} program {i}: run {run['status']}")
    finally:
        b.close()
        if arm is not None:
            shutil.rmtree(arm.tmp, ignore_errors=True)
    return res


def _plan_valid(b: Backend, arm: Arm, q0: F, gens: list[Gen], prog: int,
                res: ArmResult) -> tuple[dict[str, Any] | None, list[dict[str, Any]]]:
    """Plan; each refused step recorded (LIN / CIRC checked independently) and replaced or cut."""
    gens = list(gens)
    for _ in range(2 * len(gens) + 2):
        if not gens:
            return None, []
        steps = [g.step for g in gens]
        b.call("robot.setJointPositions", {"robot": arm.rid, "positions": [float(v) for v in q0]})
        t0 = time.perf_counter()
        plan = b.call("program.plan", {"robot": arm.rid, "steps": steps, "rate": 1 / DEFAULT_DT})
        res.plan_ms.append(1e3 * (time.perf_counter() - t0))
        if plan["valid"]:
            return plan, steps
        k = int(plan["firstFailingStep"])
        g = gens[k]
        reason = "; ".join(plan["steps"][k]["reasons"]) if k < len(plan["steps"]) else "?"
        ref = Refusal(prog, k, g.kind, reason)
        if g.kind in ("lin", "circ"):
            start = np.asarray(plan["steps"][k - 1]["target"], dtype=np.float64) if k > 0 else q0
            ref.check = follow(arm.kin, start, g.step, arm.lo, arm.hi, arm.lim.vmax)
        res.refusals.append(ref)
        if "current state" in reason:
            return None, []
        again = len(res.refusals) > 1 and res.refusals[-2].program == prog and res.refusals[-2].step == k
        if g.kind in ("joints", "detour") and again:  # stuck where the step starts: the program ends there
            gens = gens[:k]
        elif g.kind in ("joints", "detour"):
            gens.pop(k)
            if k < len(gens) and gens[k].kind in ("pose", "lin", "circ"):  # its start moved: PTP instead
                nxt = gens[k]
                step = {kk: v for kk, v in nxt.step.items() if kk in ("speed", "acceleration", "blend")}
                step["target"] = [float(v) for v in nxt.q]
                gens[k] = Gen(step, nxt.q, "joints")
        else:
            step = {kk: v for kk, v in g.step.items() if kk in ("speed", "acceleration", "blend")}
            step["target"] = [float(v) for v in g.q]
            gens[k] = Gen(step, g.q, "joints")
    return None, []


def false_refusal(r: Refusal) -> bool:
    c = r.check
    return (c is not None and c.followed and c.coal_free and c.velocity_ratio <= 1.0
            and c.min_distance >= DEFAULT_CLEARANCE)


def report(results: list[ArmResult], argv: Sequence[str]) -> None:
    print("\nrandom programs: " + " ".join(["python -m robwot_bench.program_random", *argv]))
    print("| arm | programs valid | steps | detour steps | cycle / bound max | median | LIN/CIRC refusals "
          "| false refusals | other refusals | run wall / reported worst (runs, least load average) | rests "
          "| straight rests "
          "| program.plan median | no bound | pieces over |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        lc = [x for x in r.refusals if x.kind in ("lin", "circ")]
        worst = max(r.runs, key=lambda x: abs(x[0] / x[1] - 1)) if r.runs else None
        least = min(x[2] for x in r.runs) if r.runs else 0.0
        run = f"{worst[0] / worst[1]:.3f} ({len(r.runs)} runs, {least:.1f})" if worst else "-"
        mx = f"{max(r.ratios):.3f}" if r.ratios else "-"
        md = f"{statistics.median(r.ratios):.3f}" if r.ratios else "-"
        pm = f"{statistics.median(r.plan_ms):.0f} ms" if r.plan_ms else "-"
        print(f"| {r.name} | {r.valid}/{r.programs} | {r.steps} | {r.detours} | {mx} | {md} | {len(lc)} "
              f"| {sum(map(false_refusal, lc))} | {len(r.refusals) - len(lc)} | {run} | {r.rests} "
              f"| {r.straight_rests} | {pm} | {r.bound_failures} | {r.over}/{r.pieces} |")
    print("\n| arm | program | steps | cycle time | bound | ratio |")
    print("|---|---|---|---|---|---|")
    for r in results:
        for i, n, cyc, opt in r.rows:
            print(f"| {r.name} | {i} | {n} | {cyc:.3f} s | {opt:.3f} s | {cyc / opt:.3f} |")
    refused = [(r.name, x) for r in results for x in r.refusals]
    if refused:
        print("\n| arm | program | step | kind | reason | independent IK | velocity ratio | Coal free "
              "| min distance |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name, x in refused:
            c = x.check
            ik = "-" if c is None else c.why
            vr = "-" if c is None else f"{c.velocity_ratio:.2f}"
            cf = "-" if c is None or not c.followed else str(c.coal_free)
            md = "-" if c is None or math.isnan(c.min_distance) else f"{1000 * c.min_distance:.1f} mm"
            print(f"| {name} | {x.program} | {x.step} | {x.kind} | {x.reason[:140]} | {ik} | {vr} | {cf} "
                  f"| {md} |")


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--programs", type=int, default=20, help="random programs per arm")
    ap.add_argument("--runs", type=int, default=3, help="of them program.run at real time 1, per arm")
    ap.add_argument("--steps", type=int, nargs=2, default=(6, 10), metavar=("MIN", "MAX"),
                    help="steps per program")
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--arms", nargs="+", default=list(ARMS), choices=ARMS)
    ap.add_argument("--load", type=int, default=0, help="niced busy processes while the programs run")
    ap.add_argument("--quiet", action="store_true", help="no line per program")
    return ap


def run(args: argparse.Namespace, argv: Sequence[str]) -> list[ArmResult]:
    def log(line: str) -> None:
        if not args.quiet:
            print(line, flush=True)

    t0 = time.perf_counter()
    with busy_load(args.load):
        results = [run_arm(name, args.programs, tuple(args.steps), args.runs, args.seed, log)
                   for name in args.arms]
    report(results, argv)
    program_jerk.report([program_jerk.jerk_arm(r.name, r.kept, factor, log) for r in results
                         for factor in program_jerk.JERK_FACTORS])
    print(f"\n{time.perf_counter() - t0:.0f} s, load average {os.getloadavg()[0]:.1f}")
    return results


def main(argv: list[str] | None = None) -> int:
    import sys

    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser().parse_args(argv)
    print(f"robwot random-program benchmark  python {platform.python_version()}  "
          f"cpus={len(os.sched_getaffinity(0))}  load average {os.getloadavg()[0]:.1f}")
    run(args, argv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
