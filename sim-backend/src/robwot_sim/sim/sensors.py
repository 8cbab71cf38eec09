"""Presence and colour sensors: a field of view (a box: centre, orientation, full extents; a beam is a thin
box) and what it reads of the objects.

An object is in view when its world-axis bounding box (``bounds.Body.world_box``) and the field of view's box
overlap: the separating-axis test of two oriented boxes (the 3 + 3 face axes and their 9 cross products), a
box merely touching the field of view is not in it. A sensor reads the object in view nearest the field of
view's centre (by its bounding box's centre; equal distances: by name); a colour sensor also its colour,
``[r, g, b]`` integers 0-255 from the object's ``color`` (``DEFAULT_SENSOR_COLOR`` without one). Sensors are
not bodies: robots do not collide with them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from robwot_sim.limits import DEFAULT_SENSOR_COLOR
from robwot_sim.model.rotations import quat_from_rpy, quat_matrix
from robwot_sim.sim.bounds import Body, Vector
from robwot_sim.sim.settle import Box
from robwot_sim.validate import unit_quaternion

KINDS = ("presence", "color")
#: added to the face axes' cosines so that parallel edges (a degenerate cross axis) never separate
EPS = 1e-9


@dataclass(frozen=True)
class Sensor:
    """A sensor's kind and field of view (m, quaternion [x, y, z, w], world frame)."""

    name: str
    kind: str
    size: tuple[float, float, float]
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float]

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "size": list(self.size),
                "position": list(self.position), "orientation": list(self.orientation)}

    def sees(self, box: Box) -> bool:
        """Whether the world-axis box ``box`` (min, max) overlaps the field of view."""
        lo, hi = np.asarray(box[0], dtype=np.float64), np.asarray(box[1], dtype=np.float64)
        return overlap(np.asarray(self.position), quat_matrix(self.orientation), np.asarray(self.size) / 2,
                       (lo + hi) / 2, (hi - lo) / 2)

    def reading(self, bodies: Sequence[Body], colors: dict[str, Sequence[float]]) -> dict[str, Any]:
        """What it reads of ``bodies`` (their colours by name, [0, 1] each; absent: none)."""
        centre = np.asarray(self.position)
        seen = []
        for body in bodies:
            box = body.world_box()
            if self.sees(box):
                mid = (np.asarray(box[0]) + np.asarray(box[1])) / 2
                seen.append((float(np.linalg.norm(mid - centre)), body.name))
        nearest = min(seen)[1] if seen else None
        out: dict[str, Any] = {"name": self.name, "kind": self.kind, "objectPresence": nearest is not None,
                               "object": nearest}
        if self.kind == "color":
            out["color"] = None if nearest is None else rgb(colors.get(nearest))
        return out


def rgb(color: Sequence[float] | None) -> list[int]:
    """``[r, g, b]`` 0-255 of a colour in [0, 1] (alpha dropped); the default grey without one."""
    if color is None:
        return list(DEFAULT_SENSOR_COLOR)
    return [round(float(c) * 255) for c in color[:3]]


def read_sensor(spec: dict[str, Any]) -> Sensor:
    """A scene document's sensor (validated by the scene schema)."""
    quat = unit_quaternion([float(q) for q in spec["orientation"]]) if "orientation" in spec else (
        list(quat_from_rpy(spec["rpy"])) if "rpy" in spec else [0.0, 0.0, 0.0, 1.0])
    if quat is None:  # the scene schema's check refuses it first
        raise ValueError(f"sensor {spec['name']!r}: zero quaternion")
    x, y, z = (float(c) for c in spec["size"])
    px, py, pz = (float(c) for c in spec["position"])
    qx, qy, qz, qw = quat
    return Sensor(spec["name"], spec["kind"], (x, y, z), (px, py, pz), (qx, qy, qz, qw))


def overlap(a_centre: Vector, a_axes: Vector, a_half: Vector, b_centre: Vector, b_half: Vector) -> bool:
    """Whether an oriented box (centre, axes as columns, half extents) and a world-axis box (centre, half
    extents) overlap: no separating axis among the 15 candidates (Gottschalk's OBB test; touching boxes
    are apart)."""
    r = a_axes.T  # r[i, j] = a_i . e_j: the world-axis box's axes in the oriented box's frame
    t = r @ (b_centre - a_centre)
    ar = np.abs(r) + EPS
    if np.any(np.abs(t) >= a_half + ar @ b_half):
        return False
    if np.any(np.abs(r.T @ t) >= ar.T @ a_half + b_half):
        return False
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            ra = a_half[i1] * ar[i2, j] + a_half[i2] * ar[i1, j]
            rb = b_half[j1] * ar[i, j2] + b_half[j2] * ar[i, j1]
            if abs(t[i2] * r[i1, j] - t[i1] * r[i2, j]) >= ra + rb:
                return False
    return True
