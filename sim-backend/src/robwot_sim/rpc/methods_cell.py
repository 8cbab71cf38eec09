"""`conveyor.set`, `cell.advance`, `cell.list`: the cell's conveyors and sensors (`sim/cell.py`). The
contract checks the state, speed and time step before the world is touched; the cell checks them again
for its direct callers and answers unknown conveyors with the ones it holds."""

from __future__ import annotations

from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.world_thread import Kind


def register(d: Dispatcher, s: Services) -> None:
    @d.method("conveyor.set")
    async def set_conveyor(p: Params, call: Call) -> dict[str, Any]:
        speed = float(p["speed"]) if p.has("speed") else None
        return await s.on_world(lambda: s.world.cell.set_conveyor(p["name"], p["state"], speed), Kind.PLAIN)

    @d.method("cell.advance")
    async def advance(p: Params, call: Call) -> dict[str, Any]:
        return await s.on_world(lambda: s.world.cell.advance(float(p["dt"])), Kind.PLAIN)

    @d.method("cell.list")
    async def list_(p: Params, call: Call) -> dict[str, Any]:
        return await s.on_world(s.world.cell.listing)
