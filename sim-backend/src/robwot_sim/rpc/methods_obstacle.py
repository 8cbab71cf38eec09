"""`obstacle.*` methods. The obstacle shape and pose are validated here before the world is touched."""

from __future__ import annotations

from typing import Any

from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params, check_number, check_vector, invalid_param
from robwot_sim.rpc.services import Services

_SHAPE_FIELDS: dict[str, tuple[str, ...]] = {
    "box": ("size",),
    "sphere": ("radius",),
    "cylinder": ("radius", "length"),
    "mesh": ("file", "scale"),
}


def check_shape(value: Any) -> dict[str, Any]:
    """Validate an `Obstacle.shape` object; returns a normalised copy (numbers as float)."""
    if not isinstance(value, dict):
        raise invalid_param("shape", "an object {type: box|sphere|cylinder|mesh, ...}", value)
    kind = value.get("type")
    if kind not in _SHAPE_FIELDS:
        raise invalid_param("shape.type", f"one of {sorted(_SHAPE_FIELDS)}", kind)
    allowed = {"type", *_SHAPE_FIELDS[kind]}
    for key in value:
        if key not in allowed:
            raise invalid_param(f"shape.{key}", f"no such field for a {kind}; valid: {sorted(allowed)}",
                                value[key])
    shape: dict[str, Any] = {"type": kind}
    if kind == "box":
        size = check_vector("shape.size", value.get("size"), 3)
        for i, extent in enumerate(size):
            check_number(f"shape.size[{i}]", extent, 0.0, exclusive_minimum=True)
        shape["size"] = size
    if kind in ("sphere", "cylinder"):
        shape["radius"] = check_number("shape.radius", value.get("radius"), 0.0, exclusive_minimum=True)
    if kind == "cylinder":
        shape["length"] = check_number("shape.length", value.get("length"), 0.0, exclusive_minimum=True)
    if kind == "mesh":
        file = value.get("file")
        if not isinstance(file, str) or not file:
            raise invalid_param("shape.file", "a mesh file path (string)", file)
        shape["file"] = file
        if value.get("scale") is not None:
            scale = value["scale"]
            if isinstance(scale, list):
                shape["scale"] = check_vector("shape.scale", scale, 3)
            else:
                shape["scale"] = check_number("shape.scale", scale, 0.0, exclusive_minimum=True)
    return shape


def pose_params(p: Params) -> dict[str, Any]:
    """`position` plus optional `orientation` (quaternion xyzw) or `rpy` (not both)."""
    pose: dict[str, Any] = {"position": p.vector("position", 3)}
    if p.has("orientation") and p.has("rpy"):
        raise invalid_param("rpy", "either 'orientation' or 'rpy', not both", p.raw["rpy"])
    if p.has("orientation"):
        pose["orientation"] = p.quaternion("orientation")
    if p.has("rpy"):
        pose["rpy"] = p.vector("rpy", 3)
    return pose


def register(d: Dispatcher, s: Services) -> None:
    @d.method("obstacle.add", ("name", "shape", "position", "orientation", "rpy", "color"),
              "add a static obstacle")
    async def add(p: Params, call: Call) -> dict[str, Any]:
        spec = {"name": p.string("name"), "shape": check_shape(p.obj("shape")), **pose_params(p)}
        if p.has("color"):
            color = p.vector("color")
            if len(color) not in (3, 4) or not all(0.0 <= c <= 1.0 for c in color):
                raise invalid_param("color", "[r, g, b] or [r, g, b, a] in [0, 1]", p.raw["color"])
            spec["color"] = color
        return s.world.add_obstacle(spec)

    @d.method("obstacle.move", ("name", "position", "orientation", "rpy"), "move an obstacle")
    async def move(p: Params, call: Call) -> dict[str, Any]:
        name = p.string("name")
        pose = pose_params(p)
        return s.world.move_obstacle(name, pose["position"], orientation=pose.get("orientation"),
                                     rpy=pose.get("rpy"))

    @d.method("obstacle.remove", ("name",), "remove an obstacle")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        s.world.remove_obstacle(p.string("name"))
        return {}
