"""`robot.checkPath`, `robot.plan`, `robot.move`, `robot.stop`, `program.plan`, `program.run`,
`planning.warmUp`. Ranges of
`speed`, `dt` and `realtime` are the contract's (`schemas/protocol.openrpc.json`), checked with the rest of
a request's shape before a handler runs; what a schema cannot state (a goal's rules) is checked here, once,
as the request is parsed into typed values (`Goal`, `Timing`, `ProgramStep`) the planners trust."""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from robwot_sim.limits import PLAN_BUDGET
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.kernels import KERNELS_WAIT, kernels_ready
from robwot_sim.sim.motion import load_timing
from robwot_sim.sim.planner import Goal, Plan, Timing
from robwot_sim.sim.planner import plan as plan_goal
from robwot_sim.sim.program import GRIPS, ProgramStep, plan_program
from robwot_sim.sim.world_thread import Kind


def goal_of(p: Params, dof: int) -> Goal:
    """A move's or a program step's goal: exactly one of `target` (joints: one value per controllable
    joint, by PTP only) or `position` (with `orientation` only: a quaternion of non-zero norm,
    normalised), `via` (a point of the arc) exactly with a CIRC."""
    motion = str(p["motion"])
    if motion in GRIPS:  # the gripper acts where the step before ends: no target of its own
        for name in ("target", "position", "orientation", "via"):
            if p.has(name):
                raise p.invalid(name, f"a {motion} step has no {name!r}: the gripper acts where the step "
                                "before ends")
        return Goal(motion)
    if p.has("target") == p.has("position"):
        raise p.invalid("target", "exactly one of 'target' (joints) or 'position' (pose)",
                        missing=not p.has("target"))
    if p.has("orientation") and not p.has("position"):
        raise p.invalid("orientation", "'orientation' only together with 'position'")
    if p.has("target") and motion != "ptp":
        raise p.invalid("target", f"joints only with motion 'ptp': a {motion.upper()} moves the end "
                        "effector to a 'position' (and 'orientation')")
    if p.has("via") != (motion == "circ"):
        raise p.invalid("via", "'via', a point of the arc, exactly with motion 'circ'",
                        missing=not p.has("via"))
    return Goal(motion, _tuple(p.joint_vector("target", dof)), _tuple(p.floats("position")),
                _tuple(p.quaternion("orientation")), _tuple(p.floats("via")))


def _tuple(values: list[float] | None) -> tuple[float, ...] | None:
    return None if values is None else tuple(values)


def _planner(p: Params, s: Services) -> Callable[[], Plan]:
    """The plan of a `robot.plan` or `robot.move` request."""
    model = robot_param(p, s)
    goal = goal_of(p, model.dof)
    timing = Timing(float(p["speed"]), float(p["dt"]), detour=str(p["detour"]))
    return lambda: plan_goal(s.world, model.id, goal, timing)


def program_steps(values: Sequence[Mapping[str, Any]], dof: int) -> list[ProgramStep]:
    """A program's steps as the contract checked them (its defaults filled in), each goal checked
    (``goal_of``)."""
    steps = []
    for k, raw in enumerate(values):
        step = Params(raw, where=f"steps[{k}].")
        steps.append(ProgramStep(goal_of(step, dof), float(step["speed"]), float(step["acceleration"]),
                                 float(step["tcpSpeed"]), float(step["blend"])))
    return steps


def register(d: Dispatcher, s: Services) -> None:
    warming = threading.Lock()  # held while a warm-up waits to build the bounds: one at a time

    @d.method("planning.warmUp")
    async def warm_up(p: Params, call: Call) -> dict[str, Any]:
        ready = kernels_ready()  # starts loading them when not yet
        load_timing()
        if not warming.acquire(blocking=False):
            return {"ready": ready}  # the pending one builds every robot's bounds when it runs

        def bounds() -> None:  # once the kernels are loaded, the robots' bounds built on the world's thread,
            try:  # then their self pair tables filled on this one
                if kernels_ready(timeout=KERNELS_WAIT):
                    for built in s.call_world(s.world.warm_bounds):
                        built.fill_tables()
            except Exception as err:  # the first path check builds them instead
                print(f"robwot: the robots' outer bounds were not built ahead ({err!r})", file=sys.stderr)
            finally:
                warming.release()

        s.off_world(bounds, background=True)
        return {"ready": ready}

    @d.method("robot.checkPath")
    async def check_path(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        target = p.joint_vector("target", model.dof)
        assert target is not None  # required by the contract
        start, speed, dt = p.joint_vector("from", model.dof), float(p["speed"]), float(p["dt"])
        report = await s.on_world(
            lambda: s.world.check_path(model.id, target, start=start, speed=speed, dt=dt), Kind.LONG,
            robot=model.id)
        return report.to_json()

    @d.method("program.plan")
    async def program(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        steps = program_steps(p["steps"], model.dof)
        dt, rate = float(p["dt"]), float(p["rate"])
        return await s.on_world(lambda: plan_program(s.world, model.id, steps, dt, rate).report, Kind.LONG,
                                robot=model.id, budget=PLAN_BUDGET)

    @d.method("program.run")
    async def run(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        steps = program_steps(p["steps"], model.dof)
        return await s.motions.run_program(model.id, steps, realtime=float(p["realtime"]), dt=float(p["dt"]))

    @d.method("robot.plan")
    async def plan(p: Params, call: Call) -> dict[str, Any]:
        # a long job of the world's thread: pings, stops and other robots' steps are served at its
        # checkpoints meanwhile
        model = robot_param(p, s)
        return (await s.on_world(_planner(p, s), Kind.LONG, robot=model.id, budget=PLAN_BUDGET)).to_json()

    @d.method("robot.move")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        planner = _planner(p, s)
        return await s.motions.move(str(p["robot"]), planner, realtime=float(p["realtime"]))

    @d.method("robot.stop")
    async def stop(p: Params, call: Call) -> dict[str, Any]:
        # the loop's record and the motion runner only: a stop never waits for the world
        model = robot_param(p, s)
        return {"stopped": await s.motions.stop(model.id)}
