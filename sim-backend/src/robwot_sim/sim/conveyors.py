"""Conveyor belts: a belt's state (stopped, forward, backward), speed and end stop, and one sub-step of a
running belt carrying the objects resting on it (kinematic: the objects are put where the belt takes them,
no physics; the same input gives the same poses).

A belt is a box (``[length, width, thickness]``, centre, orientation): forward is the box's local +x, its
top face (local +z) carries. Its box is also a static obstacle of the scene named as the conveyor (built from
``belt_obstacle``), so the belt's pose is the scene's: the cell reads it from there.

An object rides a belt while its lowest point (along the top face's normal) lies within
``BELT_REST_TOLERANCE`` of the top face, its centre across the belt within the width, and its centre along
it over the belt, or past the end the belt runs to while part of it is still over the belt (being carried
off). Objects on one belt queue: one stops behind the one ahead of it (their boxes along the belt) where
their boxes across it overlap. At the end: with ``end_stop`` an object stops with its edge flush with the end
(``arrived``); without, it is carried until clear of the end (``off``) and then let fall by the cell.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robwot_sim.errors import InvalidParams
from robwot_sim.limits import BELT_REST_TOLERANCE, DEFAULT_BELT_SPEED, MAX_BELT_SPEED
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.bounds import Body, Vector

STATES = ("stopped", "forward", "backward")
#: below this (m) a move, an overlap or a gap is none (rounding)
EPS = 1e-9


@dataclass
class Conveyor:
    """A conveyor's own state (its belt's box is the scene obstacle of its name)."""

    name: str
    speed: float = DEFAULT_BELT_SPEED
    end_stop: bool = True
    state: str = "stopped"

    def set(self, state: str, speed: float | None = None) -> bool:
        """Run it ``forward``, ``backward`` or stop it, at ``speed`` (m/s; None: as it is), both checked
        first; whether anything changed."""
        if state not in STATES:
            raise InvalidParams(f"state must be one of {', '.join(STATES)}", param="state",
                                expected=list(STATES), got=state)
        if speed is not None:
            check_speed(speed)
        before = (self.state, self.speed)
        self.state = state
        self.speed = self.speed if speed is None else float(speed)
        return before != (self.state, self.speed)

    @property
    def sign(self) -> int:
        """+1 running forward, -1 backward, 0 stopped."""
        return {"forward": 1, "backward": -1}.get(self.state, 0)

    def to_json(self, belt: dict[str, Any]) -> dict[str, Any]:
        """The conveyor as the world holds it, its belt's box from the scene obstacle ``belt``."""
        out: dict[str, Any] = {"name": self.name, "size": list(belt["shape"]["size"]),
                               "position": list(belt["position"]), "orientation": list(belt["orientation"]),
                               "speed": self.speed, "endStop": self.end_stop, "state": self.state}
        if "color" in belt:
            out["color"] = list(belt["color"])
        return out


def check_speed(speed: Any) -> float:
    number = isinstance(speed, int | float) and not isinstance(speed, bool)
    if not number or not 0.0 < speed <= MAX_BELT_SPEED:
        raise InvalidParams(f"speed must be in (0, {MAX_BELT_SPEED:g}] m/s", param="speed",
                            expected=f"number in (0, {MAX_BELT_SPEED:g}]", got=speed)
    return float(speed)


def read_conveyor(spec: dict[str, Any]) -> tuple[Conveyor, dict[str, Any]]:
    """A scene document's conveyor (validated by the scene schema): its state and its belt's obstacle spec
    (a box, to be read as any obstacle)."""
    conveyor = Conveyor(spec["name"], float(spec.get("speed", DEFAULT_BELT_SPEED)),
                        bool(spec.get("endStop", True)), str(spec.get("state", "stopped")))
    keys = ("name", "position", "orientation", "rpy", "color")
    belt: dict[str, Any] = {k: spec[k] for k in keys if k in spec}
    return conveyor, {**belt, "shape": {"type": "box", "size": [float(s) for s in spec["size"]]}}


@dataclass
class Belt:
    """A belt's box where it is now (from its scene obstacle spec)."""

    centre: Vector
    axes: Vector  # columns: along (forward), across, up (the top face's normal)
    size: Sequence[float]

    @classmethod
    def of(cls, obstacle: dict[str, Any]) -> Belt:
        return cls(np.asarray(obstacle["position"], dtype=np.float64), quat_matrix(obstacle["orientation"]),
                   [float(s) for s in obstacle["shape"]["size"]])

    def span(self, body: Body, k: int, sign: int = 1) -> tuple[float, float]:
        """(lowest, highest) of ``body`` along the belt's axis ``k`` (times ``sign``), from its centre."""
        axis = sign * self.axes[:, k]
        lo, hi = body.interval(axis)
        offset = float(axis @ self.centre)
        return lo - offset, hi - offset

    def rides(self, body: Body, sign: int) -> bool:
        """Whether ``body`` rides the belt running ``sign`` (module docstring)."""
        length, width, thickness = self.size
        bottom = self.span(body, 2)[0] - thickness / 2
        across = sum(self.span(body, 1)) / 2
        lo, hi = self.span(body, 0, sign)
        along = (lo + hi) / 2
        over = abs(along) <= length / 2 or (along > length / 2 and lo < length / 2 - EPS)
        return abs(bottom) <= BELT_REST_TOLERANCE and abs(across) <= width / 2 and over


@dataclass
class Carried:
    """What one sub-step of a belt did: the bodies moved (by name, as they are now), those that reached the
    end stop, those carried clear of the end."""

    moved: dict[str, Body] = field(default_factory=dict)
    arrived: list[str] = field(default_factory=list)
    off: list[str] = field(default_factory=list)


def carry(conveyor: Conveyor, belt: Belt, bodies: Sequence[Body], distance: float) -> Carried:
    """One sub-step of ``conveyor`` (running) over ``bodies``: those riding it moved ``distance`` (m) along
    its direction, the most advanced first, each at most to the end stop or the body ahead of it."""
    sign, out = conveyor.sign, Carried()
    length = belt.size[0] / 2
    riding = [b for b in bodies if belt.rides(b, sign)]
    riding.sort(key=lambda b: (-sum(belt.span(b, 0, sign)), b.name))
    ahead: list[Body] = []
    for body in riding:
        lo, hi = belt.span(body, 0, sign)
        limit = distance
        if conveyor.end_stop:
            limit = min(limit, length - hi)
        across = belt.span(body, 1)
        for other in ahead:  # processed already: farther along, where they are now
            o_across = belt.span(other, 1)
            if min(across[1], o_across[1]) - max(across[0], o_across[0]) > EPS:
                limit = min(limit, belt.span(other, 0, sign)[0] - hi)
        if limit > EPS:
            body = body.moved(sign * limit * belt.axes[:, 0])
            out.moved[body.name] = body
            if conveyor.end_stop and hi + limit >= length - EPS:
                out.arrived.append(body.name)
            elif not conveyor.end_stop and lo + limit >= length - EPS:
                out.off.append(body.name)
        ahead.append(body)
    return out


def running_belts(conveyors: dict[str, Conveyor], obstacles: Sequence[dict[str, Any]]) -> dict[str, Belt]:
    """The running conveyors' belts by conveyor name (sorted), from the scene's obstacle specs."""
    specs = {o["name"]: o for o in obstacles}
    return {name: Belt.of(specs[name]) for name in sorted(conveyors)
            if name in specs and conveyors[name].sign != 0}
