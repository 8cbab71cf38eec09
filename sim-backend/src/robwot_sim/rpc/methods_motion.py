"""`robot.checkPath`, `robot.move`, `robot.stop`."""

from __future__ import annotations

from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import joint_vector, robot_param
from robwot_sim.rpc.params import MISSING, Params, invalid_param
from robwot_sim.rpc.services import Services

DEFAULT_DT = 1.0 / 240.0
#: slowest speed fraction (a move then takes 1,000 times its full-speed duration); the TD says the same
MIN_SPEED = 1e-3
#: shortest time step (s): below, even a short motion needs more steps than the motion planner allows
MIN_DT = 1e-4


def _timing(p: Params) -> tuple[float, float]:
    speed = p.number("speed", 1.0, minimum=MIN_SPEED, maximum=1.0)
    dt = p.number("dt", DEFAULT_DT, minimum=MIN_DT, maximum=0.1)
    return float(speed), float(dt)


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.checkPath", ("robot", "target", "from", "speed", "dt"),
              "check the interpolated path for collision without moving")
    async def check_path(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        target = joint_vector(p, "target", model, MISSING)
        start = joint_vector(p, "from", model)
        speed, dt = _timing(p)
        return s.world.check_path(model.id, target, start=start, speed=speed, dt=dt).to_json()

    @d.method("robot.move", ("robot", "target", "speed", "realtime", "dt"),
              "move to a joint target; answers when the motion ends")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        target = joint_vector(p, "target", model, MISSING)
        speed, dt = _timing(p)
        realtime = float(p.number("realtime", 1.0, minimum=0.0, maximum=1000.0))
        if 0.0 < realtime < 0.01:
            raise invalid_param("realtime", "0 (as fast as possible) or a factor in [0.01, 1000]", realtime)
        return await s.motions.move(model.id, target, speed=speed, realtime=realtime, dt=dt)

    @d.method("robot.stop", ("robot",), "stop the robot's motion in progress; answers once it has stopped")
    async def stop(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return {"stopped": await s.motions.stop(model.id)}
