"""`gripper.*` methods: a robot's gripper declared, closed on the object at its TCP (held: part of the
robot in every check) and opened (the object let go, settled). Closing or opening a moving robot is
refused (`E_BUSY`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from robwot_sim.errors import Busy
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.methods_robot import robot_param
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.world_thread import Kind


def register(d: Dispatcher, s: Services) -> None:
    async def changing(p: Params, fn: Callable[[str], dict[str, Any]]) -> dict[str, Any]:
        """``fn`` on the world's thread for a robot that is not moving; its joints after it added."""
        model = robot_param(p, s)
        if s.motions.is_moving(model.id):
            raise Busy(model.id)

        def run() -> dict[str, Any]:
            out = fn(model.id)
            return {**out, "positions": [float(v) for v in s.world.get_joint_positions(model.id)]}

        return await s.change_world(run, Kind.LONG)

    @d.method("gripper.configure")
    async def configure(p: Params, call: Call) -> dict[str, Any]:
        joints = p["joints"]
        return await changing(p, lambda rid: s.world.grippers.configure(
            rid, p["kind"], [str(j) for j in joints] if joints is not None else None, float(p["time"]),
            float(p["capture"])))

    @d.method("gripper.close")
    async def close(p: Params, call: Call) -> dict[str, Any]:
        return await changing(p, s.world.grippers.close)

    @d.method("gripper.open")
    async def open_(p: Params, call: Call) -> dict[str, Any]:
        return await changing(p, s.world.grippers.open)

    @d.method("gripper.state")
    async def state(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return await s.on_world(lambda: {**s.world.grippers.state(model.id), "positions": [
            float(v) for v in s.world.get_joint_positions(model.id)]}, robot=model.id)
