"""`robot.checkPath`, `robot.plan`, `robot.move`, `robot.stop`. Ranges of `speed`, `dt` and `realtime`
are the contract's (`schemas/protocol.openrpc.json`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robwot_sim.limits import PLAN_BUDGET
from robwot_sim.rpc.contract import invalid_param
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.planner import Plan, plan_joints, plan_lin, plan_pose
from robwot_sim.sim.program import plan_program
from robwot_sim.sim.world_thread import Kind


def _planner(p: Params, s: Services) -> Callable[[], Plan]:
    """The plan of a `target` (joints) or `position` (+ `orientation`) param: exactly one of them."""
    model = robot_param(p, s)
    if p.has("target") == p.has("position"):
        raise invalid_param("target", "exactly one of 'target' (joints) or 'position' (pose)",
                            p["target"], missing=not p.has("target"))
    if p.has("orientation") and not p.has("position"):
        raise invalid_param("orientation", "'orientation' only together with 'position'", p["orientation"])
    speed, dt = float(p["speed"]), float(p["dt"])
    target = p.joint_vector("target", model.dof)
    if p.has("via") and p["motion"] != "circ":
        raise invalid_param("via", "'via' only with motion 'circ'", p["via"])
    if p["motion"] in ("lin", "circ"):
        if target is not None:
            raise invalid_param("motion", f"'{p['motion']}' moves the end effector to a pose: give "
                                "'position' (and 'orientation'), not 'target'", p["motion"])
        if p["motion"] == "circ" and not p.has("via"):
            raise invalid_param("via", "motion 'circ' needs 'via', a point of the arc", None, missing=True)
        pose, turn, through = p.floats("position"), p.quaternion("orientation"), p.floats("via")
        assert pose is not None
        return lambda: plan_lin(s.world, model.id, pose, turn, through, speed=speed)
    if target is not None:
        joints = target
        return lambda: plan_joints(s.world, model.id, joints, speed, dt)
    position, orientation = p.floats("position"), p.quaternion("orientation")
    assert position is not None
    return lambda: plan_pose(s.world, model.id, position, orientation, speed, dt)


def _program_steps(p: Params, dof: int) -> list[dict[str, Any]]:
    """A program's steps, each with exactly one target, joint targets of ``dof`` values by PTP only, and
    ``via`` exactly with a CIRC."""
    steps = [dict(step) for step in p["steps"]]
    for k, step in enumerate(steps):
        motion = step.get("motion", "ptp")
        if ("target" in step) == ("position" in step):
            raise invalid_param(f"steps[{k}]", "exactly one of 'target' (joints) or 'position' (pose)", step)
        if "target" in step and (motion != "ptp" or len(step["target"]) != dof):
            raise invalid_param(f"steps[{k}].target", f"{dof} joint values, with motion 'ptp'", step)
        if ("via" in step) != (motion == "circ"):
            raise invalid_param(f"steps[{k}].via", "'via' exactly with motion 'circ'", step)
    return steps


def register(d: Dispatcher, s: Services) -> None:
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
        steps = _program_steps(p, model.dof)
        dt, rate = float(p["dt"]), float(p["rate"])
        return await s.on_world(lambda: plan_program(s.world, model.id, steps, dt, rate).report, Kind.LONG,
                                robot=model.id, budget=PLAN_BUDGET)

    @d.method("program.run")
    async def run(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        steps = _program_steps(p, model.dof)
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
        return await s.motions.move(str(p["robot"]), planner, speed=float(p["speed"]),
                                    realtime=float(p["realtime"]), dt=float(p["dt"]))

    @d.method("robot.stop")
    async def stop(p: Params, call: Call) -> dict[str, Any]:
        # the loop's record and the motion runner only: a stop never waits for the world
        model = robot_param(p, s)
        return {"stopped": await s.motions.stop(model.id)}
