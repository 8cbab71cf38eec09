"""`robot.checkPath`, `robot.move`, `robot.stop`. Ranges of `speed`, `dt` and `realtime` are the
contract's (`schemas/protocol.openrpc.json`)."""

from __future__ import annotations

from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.checkPath")
    async def check_path(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        target = p.joint_vector("target", model.dof)
        assert target is not None  # required by the contract
        return s.world.check_path(model.id, target, start=p.joint_vector("from", model.dof),
                                  speed=float(p["speed"]), dt=float(p["dt"])).to_json()

    @d.method("robot.move")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        target = p.joint_vector("target", model.dof)
        assert target is not None  # required by the contract
        return await s.motions.move(model.id, target, speed=float(p["speed"]), realtime=float(p["realtime"]),
                                    dt=float(p["dt"]))

    @d.method("robot.stop")
    async def stop(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return {"stopped": await s.motions.stop(model.id)}
