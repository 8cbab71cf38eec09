"""`robot.expandXacro`: a xacro file expanded into a URDF file (xacro_expand.py). Needs no world: it runs
in a thread of its own around the xacro child process, so the loop and the world keep serving."""

from __future__ import annotations

from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.xacro_expand import expand_xacro


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.expandXacro")
    async def expand(p: Params, call: Call) -> dict[str, Any]:
        args = {str(k): str(v) for k, v in dict(p["args"]).items()}
        roots = {str(k): str(v) for k, v in dict(p["packageRoots"] or {}).items()}
        urdf, package_roots = await s.off_world(lambda: expand_xacro(p["xacro"], args, roots))
        return {"urdf": str(urdf), "packageRoots": package_roots}
