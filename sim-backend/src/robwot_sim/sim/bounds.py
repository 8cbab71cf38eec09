"""How far a body reaches, from its shape and pose: its support along a direction (the farthest any of its
points lies that way) and its world-axis bounding box. What the conveyors (an object's bottom, its edges
along a belt) and the sensors (its bounding box) measure objects with (``cell.py``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt

from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.client import HULL
from robwot_sim.sim.settle import Box, Placed

Vector = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Body:
    """An object as the cell measures it: its name, shape (as built) and pose, and, for a mesh whose points
    we do not hold (a DAE, a huge hull), PyBullet's bounding box of it."""

    name: str
    placed: Placed
    box: Box | None = None
    #: its rotation matrix, computed once (a translated copy keeps it)
    rot: Vector | None = field(default=None, compare=False, repr=False)

    def rotation(self) -> Vector:
        if self.rot is None:
            object.__setattr__(self, "rot", quat_matrix(self.placed.orientation))
        assert self.rot is not None
        return self.rot

    def _half(self) -> Vector:
        """A box's half extents (m)."""
        return np.asarray(self.placed.shape["size"], dtype=np.float64) / 2

    def support(self, direction: Sequence[float] | Vector) -> float:
        return support(self.placed, direction, self.box, self.rotation())

    def interval(self, axis: Sequence[float] | Vector) -> tuple[float, float]:
        """(lowest, highest) of its points along unit ``axis``."""
        a = np.asarray(axis, dtype=np.float64)
        if self.placed.shape["type"] == "box":  # symmetric: its centre +- its reach along the axis
            centre = float(a @ np.asarray(self.placed.position, dtype=np.float64))
            reach = float(np.abs(a @ self.rotation()) @ self._half())
            return centre - reach, centre + reach
        return -self.support(-a), self.support(a)

    def world_box(self) -> Box:
        """Its world-axis bounding box (min, max corners, m)."""
        if self.placed.shape["type"] == "box":  # the support along each axis at once
            p = np.asarray(self.placed.position, dtype=np.float64)
            reach = np.abs(self.rotation()) @ self._half()
            lo_box, hi_box = (p - reach).tolist(), (p + reach).tolist()
            return (lo_box[0], lo_box[1], lo_box[2]), (hi_box[0], hi_box[1], hi_box[2])
        lo, hi = zip(*(self.interval(e) for e in np.eye(3)), strict=True)
        return tuple(lo), tuple(hi)

    def moved(self, delta: Vector) -> Body:
        """The same body translated by ``delta`` (m)."""
        position = [float(p + d) for p, d in zip(self.placed.position, delta, strict=True)]
        box = None
        if self.box is not None:
            (lx, ly, lz), (hx, hy, hz) = self.box
            dx, dy, dz = (float(d) for d in delta)
            box = ((lx + dx, ly + dy, lz + dz), (hx + dx, hy + dy, hz + dz))
        return replace(self, placed=replace(self.placed, position=position), box=box)


def support(placed: Placed, direction: Sequence[float] | Vector, box: Box | None = None,
            rot: Vector | None = None) -> float:
    """max over the body's points p of ``direction . p`` (m for a unit direction): exact for spheres,
    cylinders, boxes and meshes with their hull; from ``box`` (PyBullet's bounding box) otherwise.
    ``rot``: its rotation matrix, when known."""
    d = np.asarray(direction, dtype=np.float64)
    p = np.asarray(placed.position, dtype=np.float64)
    rot = quat_matrix(placed.orientation) if rot is None else rot
    s = placed.shape
    if s["type"] == "sphere":
        return float(d @ p + s["radius"] * np.linalg.norm(d))
    if s["type"] == "cylinder":  # along its local z
        du = float(d @ rot[:, 2])
        across = math.sqrt(max(0.0, float(d @ d) - du * du))
        return float(d @ p + abs(du) * s["length"] / 2 + s["radius"] * across)
    if s["type"] == "box":
        return float(d @ p + np.abs(d @ rot) @ (np.asarray(s["size"], dtype=np.float64) / 2))
    if s.get(HULL) is not None:
        points = np.asarray(s[HULL], dtype=np.float64) @ rot.T
        return float(d @ p + (points @ d).max())
    if box is None:
        raise ValueError(f"a {s['type']} without its points needs its bounding box")
    lo, hi = np.asarray(box[0], dtype=np.float64), np.asarray(box[1], dtype=np.float64)
    return float(d @ (lo + hi) / 2 + np.abs(d) @ (hi - lo) / 2)
