"""`obstacle.*` and `object.*` methods (an object is an obstacle that settles and moves). Shapes,
positions, colours and masses are checked by the contract before the world is touched; what it cannot say
(orientation xor rpy, a quaternion's norm) is checked here."""

from __future__ import annotations

from typing import Any

from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.rpc.contract import invalid_param
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.scene_files import ReadObstacle, read_object, read_obstacle
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


def _spec(p: Params) -> dict[str, Any]:
    """An `obstacle.add` / `object.add` request's body spec."""
    spec = {"name": p["name"], "shape": _shape(p["shape"]), **pose_params(p)}
    if p.has("color"):
        spec["color"] = p.floats("color")
    return spec


async def _read(s: Services, spec: dict[str, Any], kind: str) -> ReadObstacle:
    """The spec read: a mesh is parsed off the world's thread (it may be large); the world then only
    creates the body."""
    read = read_object if kind == "objects" else read_obstacle
    if spec["shape"]["type"] == "mesh":
        return await s.off_world(lambda: read(spec), background=True)
    return read(spec)


def _new_pose(p: Params) -> tuple[list[float], list[float] | None]:
    """A move's position and orientation (quaternion; None: keep the current one)."""
    pose = pose_params(p)
    quat = pose.get("orientation") or (list(quat_from_rpy(pose["rpy"])) if "rpy" in pose else None)
    return pose["position"], quat


def register(d: Dispatcher, s: Services) -> None:
    @d.method("obstacle.add")
    async def add(p: Params, call: Call) -> dict[str, Any]:
        read = await _read(s, _spec(p), "obstacles")
        return await s.on_world(lambda: s.world.add_obstacle(read), Kind.PLAIN)

    @d.method("obstacle.move")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        position, quat = _new_pose(p)
        return await s.on_world(lambda: s.world.move_obstacle(p["name"], position, quat), Kind.PLAIN)

    @d.method("obstacle.remove")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        await s.on_world(lambda: s.world.remove_obstacle(p["name"]), Kind.PLAIN)
        return {}

    @d.method("object.add")
    async def add_object(p: Params, call: Call) -> dict[str, Any]:
        read = await _read(s, {**_spec(p), "mass": float(p["mass"])}, "objects")
        return await s.on_world(lambda: s.world.add_object(read), Kind.PLAIN)

    @d.method("object.move")
    async def move_object(p: Params, call: Call) -> dict[str, Any]:
        position, quat = _new_pose(p)
        return await s.on_world(lambda: s.world.move_object(p["name"], position, quat), Kind.PLAIN)

    @d.method("object.remove")
    async def remove_object(p: Params, call: Call) -> dict[str, Any]:
        await s.on_world(lambda: s.world.remove_object(p["name"]), Kind.PLAIN)
        return {}
