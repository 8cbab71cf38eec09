"""Leaving a state in contact, as MoveIt lets a plan leave a start state in collision.

A robot can stand in contact: loaded into a scene that overlaps its start pose, or stopped on a contact.
Every path from such a state collides at its first state, so no move would ever get it out. A path is
allowed out of it when, along its first states, the contact only recedes until none is left:

- the states are walked in order (the path's rows, subdivided) so that no point of the robot travels
  more than the guard's sweep between two checked states;
- at each checked state every touching pair (robot link, other body or link) was touching at the state
  before, and the penetration, the depths of the pairs summed (each pair's deepest point: Bullet's
  distance inside a body is negative), is strictly smaller: a path that goes deeper, touches something
  new or only slides along is refused there. One pair's depth alone may rise a little while the sum
  falls: Bullet's depth between convex hulls moves to another feature as they turn;
- the first checked state with no contact ends the exit; from there on the normal path check applies.

``leave_contact`` walks a path and says where it is free, or where and how it stopped receding.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from robwot_sim.sim.collision import CollisionChecker
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.sweep import Guard, substeps
from robwot_sim.sim.timed import TimedPath
from robwot_sim.sim.types import BodyLink, Contact, FloatArray

Pair = tuple[BodyLink, BodyLink]


@dataclass(frozen=True)
class Exit:
    """How a path starting in contact leaves it: ``free_at`` the fractional index (in the path's states) of
    the first checked state with no contact, or None when the contact did not recede until then;
    ``start`` the contacts of the first state; ``at``/``positions``/``contacts`` where the exit was
    refused (fractional state index, the state, its contacts), the path's last state when it never got
    free."""

    free_at: float | None
    start: tuple[Contact, ...]
    at: float = 0.0
    positions: tuple[float, ...] = ()
    contacts: tuple[Contact, ...] = ()


def _depths(contacts: list[Contact]) -> dict[Pair, float]:
    out: dict[Pair, float] = {}
    for c in contacts:
        key = (c.a, c.b) if (c.a.body, c.a.link or "") <= (c.b.body, c.b.link or "") else (c.b, c.a)
        out[key] = max(out.get(key, 0.0), c.depth)
    return out


def receding(before: dict[Pair, float], now: dict[Pair, float]) -> bool:
    """Every pair of ``now`` was in ``before``, and the summed depth is smaller."""
    return all(pair in before for pair in now) and sum(now.values()) < sum(before.values())


def walk(path: TimedPath, guard: Guard) -> Iterator[tuple[float, FloatArray]]:
    """The path's states after its first, as (fractional state index, state), such that no point of the
    robot travels more than the guard's sweep between two consecutive ones: the rows, each step between
    two rows subdivided (``sweep.substeps``), a state skipped while the travel from the last one yielded
    to the next candidate stays within the sweep. The last state is always yielded."""
    last = len(path) - 1
    pending: tuple[float, FloatArray] | None = None
    since = 0.0  # travel from the last state yielded to ``pending``
    q0 = path.first
    for k in range(last):
        q1 = path[k + 1]
        n = substeps(q0, q1, guard.reach, guard.max_sweep)
        step = float(np.sum(np.abs(q1 - q0) * guard.reach)) / n
        for i in range(1, n + 1):
            if pending is not None and since + step > guard.max_sweep:
                yield pending
                since = 0.0
            pending = (k + i / n, q0 + (q1 - q0) * (i / n))
            since += step
        q0 = q1
    if pending is not None:
        yield pending


def leave_contact(robot: BoundRobot, checker: CollisionChecker, path: TimedPath, guard: Guard) -> Exit:
    """Walks ``path`` from its first state (in contact) while the contact recedes (module doc). Leaves the
    robot at the last state checked."""
    robot.apply(path.first)
    start = checker.contacts()
    before = _depths(start)
    now: list[Contact] = start
    at, q = 0.0, path.first
    for at, q in walk(path, guard):
        robot.apply(q)
        if checker.is_free():
            return Exit(at, tuple(start))
        now = checker.contacts()
        depths = _depths(now)
        if not receding(before, depths):
            break
        before = depths
    return Exit(None, tuple(start), at, tuple(float(x) for x in q), tuple(now))
