"""`obstacle.*` methods. Shapes, positions and colours are checked by the contract before the world is
touched; what it cannot say (orientation xor rpy, a quaternion's norm) is checked here."""

from __future__ import annotations

from typing import Any

from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.rpc.contract import invalid_param
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.scene_files import read_obstacle
from robwot_sim.sim.world_thread import Kind


def pose_params(p: Params) -> dict[str, Any]:
    """`position` plus optional `orientation` (quaternion xyzw, normalised) or `rpy` (not both)."""
    pose: dict[str, Any] = {"position": p.floats("position")}
    if p.has("orientation") and p.has("rpy"):
        raise invalid_param("rpy", "either 'orientation' or 'rpy', not both", p["rpy"])
    if p.has("orientation"):
        pose["orientation"] = p.quaternion("orientation")
    if p.has("rpy"):
        pose["rpy"] = p.floats("rpy")
    return pose


def _shape(value: dict[str, Any]) -> dict[str, Any]:
    """A contract-valid shape with its numbers as floats."""
    return {k: (v if isinstance(v, str) else [float(x) for x in v] if isinstance(v, list) else float(v))
            for k, v in value.items()}


def register(d: Dispatcher, s: Services) -> None:
    @d.method("obstacle.add")
    async def add(p: Params, call: Call) -> dict[str, Any]:
        spec = {"name": p["name"], "shape": _shape(p["shape"]), **pose_params(p)}
        if p.has("color"):
            spec["color"] = p.floats("color")
        # a mesh is parsed off the world's thread (it may be large); the world then only creates the body
        mesh = spec["shape"]["type"] == "mesh"
        read = (await s.off_world(lambda: read_obstacle(spec), background=True) if mesh
                else read_obstacle(spec))
        return await s.on_world(lambda: s.world.add_obstacle(read), Kind.PLAIN)

    @d.method("obstacle.move")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        pose = pose_params(p)
        quat = pose.get("orientation") or (quat_from_rpy(pose["rpy"]) if "rpy" in pose else None)
        return await s.on_world(lambda: s.world.move_obstacle(p["name"], pose["position"], quat), Kind.PLAIN)

    @d.method("obstacle.remove")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        await s.on_world(lambda: s.world.remove_obstacle(p["name"]), Kind.PLAIN)
        return {}
