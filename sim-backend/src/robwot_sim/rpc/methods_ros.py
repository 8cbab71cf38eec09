"""Robots as ROS users have them, read without a world (each in a thread of its own, so the loop and the
world keep serving): `robot.expandXacro` (xacro_expand.py), `robot.moveitConfig` (moveit_config.py),
`robot.readSrdf` (srdf.py, every name checked against the URDF), `robot.attachTool` (tool.py)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robwot_sim.model.moveit_config import find_moveit_config
from robwot_sim.model.moveit_config import joint_limits as read_joint_limits
from robwot_sim.model.srdf import read_srdf
from robwot_sim.model.tool import attach_tool
from robwot_sim.model.urdf import parse_urdf
from robwot_sim.model.xacro_expand import expand_xacro
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services


def _strings(value: Any) -> dict[str, str]:
    return {str(k): str(v) for k, v in dict(value or {}).items()}


def _srdf(srdf: str, urdf: str) -> dict[str, Any]:
    root = parse_urdf(urdf).root
    links = {str(el.get("name")) for el in root.findall("link")}
    joints = {str(el.get("name")) for el in root.findall("joint")}
    return read_srdf(srdf, links, joints).to_json()


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.expandXacro")
    async def expand(p: Params, call: Call) -> dict[str, Any]:
        args, roots = _strings(p["args"]), _strings(p["packageRoots"])
        limits = {str(k): float(v) for k, v in dict(p["velocityLimits"]).items()}
        positions = {str(k): (float(v[0]), float(v[1])) for k, v in dict(p["positionLimits"]).items()}
        urdf, package_roots = await s.off_world(
            lambda: expand_xacro(p["xacro"], args, roots, limits, positions))
        return {"urdf": str(urdf), "packageRoots": package_roots}

    @d.method("robot.moveitConfig")
    async def moveit(p: Params, call: Call) -> dict[str, Any]:
        roots = _strings(p["packageRoots"])
        config = await s.off_world(lambda: find_moveit_config(p["dir"], roots))
        return config.to_json()

    @d.method("robot.jointLimits")
    async def joint_limits(p: Params, call: Call) -> dict[str, Any]:
        file = Path(p["file"]).expanduser()
        limits = await s.off_world(lambda: read_joint_limits(file, required=True))
        return {"velocityLimits": limits.velocities, "accelerationLimits": limits.accelerations,
                "jerkLimits": limits.jerks,
                "positionLimits": {k: list(v) for k, v in limits.positions.items()}}

    @d.method("robot.readSrdf")
    async def srdf(p: Params, call: Call) -> dict[str, Any]:
        return await s.off_world(lambda: _srdf(p["srdf"], p["urdf"]))

    @d.method("robot.attachTool")
    async def tool(p: Params, call: Call) -> dict[str, Any]:
        roots = _strings(p["packageRoots"])
        tcp = [float(v) for v in p["tcp"]]
        mesh = p["mesh"] if p.has("mesh") else None
        shape = dict(p["shape"]) if p.has("shape") else None
        done = await s.off_world(lambda: attach_tool(p["urdf"], roots, p["eeLink"], tcp, mesh, shape))
        return {"urdf": str(done.urdf), "packageRoots": done.package_roots, "flange": done.flange,
                "tcpLink": done.tcp_link}
