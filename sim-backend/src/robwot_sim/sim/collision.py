"""Self and environment collision of a robot, with pair names and penetration depth.

How: moving links go through Bullet's broadphase (``performCollisionDetection`` +
``getContactPoints``). Links that never move (the fixed base and links fixed to it) are static to Bullet,
which never pairs them with static obstacles, so they are checked with ``getClosestPoints(distance=0)``
once per world change and cached. Moving links without mass (static to Bullet too) use
``getClosestPoints`` at every check. Pairs touching in >= 95 % of random configurations are filtered
at load (``setCollisionFilterPair``), e.g. Panda link7/hand.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from robwot_sim.sim.client import ContactPoint, Recheck
from robwot_sim.sim.robot import BoundRobot
from robwot_sim.sim.types import BodyLink, Contact, FloatArray
from robwot_sim.sim.world_thread import checkpoint

ALWAYS_FRACTION = 0.95
FILTER_SAMPLES = 200
TOUCH = 0.0  # contact points with distance <= TOUCH (m) count as collision


@dataclass
class BodyTable:
    """Names of every body in the world, for naming contact pairs."""

    names: dict[int, str] = field(default_factory=dict)  # body id -> robot id / obstacle name
    robots: dict[int, BoundRobot] = field(default_factory=dict)  # body id -> robot
    version: int = 0  # bumped on every world change (invalidates static caches)

    def side(self, body: int, link: int) -> BodyLink:
        r = self.robots.get(body)
        if r is None:
            return BodyLink(self.names.get(body, str(body)), None)
        return BodyLink(self.names[body], r.link_names.get(link))


def find_always_colliding(
    robot: BoundRobot, rng: np.random.Generator, samples: int = FILTER_SAMPLES
) -> list[tuple[int, int]]:
    """Self-collision link pairs touching in >= 95 % of random configurations (link indices, a < b)."""
    counts: dict[tuple[int, int], int] = {}
    b = robot.bullet
    saved = robot.q.copy()
    for q in robot.random_q(rng, samples):
        checkpoint()  # a load in progress: the body is in no one's table yet (world_thread.py)
        robot.apply(q)
        b.detect()
        seen = {
            (min(c.link_a, c.link_b), max(c.link_a, c.link_b))
            for c in b.contacts(robot.body, robot.body)
            if c.distance <= TOUCH
        }
        for pair in seen:
            counts[pair] = counts.get(pair, 0) + 1
    robot.apply(saved)
    return sorted(p for p, n in counts.items() if n >= ALWAYS_FRACTION * samples)


#: ``CollisionChecker.sure_free``: (states, clearance, states not known free to stop after) -> (free, tested)
SureFree = Callable[[npt.NDArray[np.float64], float, int], tuple[npt.NDArray[np.bool_], int]]


class CollisionChecker:
    """Collision queries for one robot against itself and every other body of the world. ``sure_free``
    (set by the scene it belongs to): of states (rows of joint vectors), those surely farther than a
    clearance (m) from every other body and free of self-contact without asking Bullet (the outer bounds),
    so that ``is_free`` would say so, tested in order until a number of states not known free are met (0:
    every state), and how many were tested; None: none known."""

    sure_free: SureFree | None = None

    def __init__(self, robot: BoundRobot, table: BodyTable, filtered: Iterable[tuple[int, int]]) -> None:
        self.robot, self.table = robot, table
        self.filtered = {(min(a, b), max(a, b)) for a, b in filtered}
        for a, b in self.filtered:
            robot.bullet.set_pair_filter(robot.body, robot.body, a, b, False)
        masses = robot.bullet.link_masses(robot.body, robot.moving_links)
        self.massless_moving = [
            ln
            for ln, m in zip(robot.moving_links, masses, strict=True)
            if m <= 0 and robot.bullet.has_collision_shape(robot.body, ln)
        ]
        self.static_links = [
            ln for ln in robot.static_links if robot.bullet.has_collision_shape(robot.body, ln)
        ]
        self._static: list[Contact] | None = None
        self.recheck = Recheck(robot.bullet.cid, robot.body)
        self._static_version = -1

    def _others(self) -> list[int]:
        return [b for b in self.table.names if b != self.robot.body]

    def _contact(self, c: ContactPoint) -> Contact:
        if c.body_a != self.robot.body and c.body_b == self.robot.body:
            a, b = self.table.side(c.body_b, c.link_b), self.table.side(c.body_a, c.link_a)
        else:
            a, b = self.table.side(c.body_a, c.link_a), self.table.side(c.body_b, c.link_b)
        return Contact(a, b, max(0.0, -c.distance), c.position_on_a)

    def _closest_links(self, links: Iterable[int], clearance: float = TOUCH) -> list[ContactPoint]:
        bl = self.robot.bullet
        out: list[ContactPoint] = []
        for other in self._others():
            for ln in links:
                out += [
                    c
                    for c in bl.closest(self.robot.body, other, clearance, link_a=ln)
                    if c.distance <= clearance
                ]
        return out

    def static_contacts(self) -> list[Contact]:
        """Contacts of the links that never move with static things (cached until the world changes)."""
        if self._static is None or self._static_version != self.table.version:
            bl, body = self.robot.bullet, self.robot.body
            pts: list[ContactPoint] = []
            for other in self._others():
                robot = self.table.robots.get(other)
                # other robots: only their static links (their moving links are found by detect())
                targets: list[int | None] = [None] if robot is None else list(robot.static_links)
                for ln in self.static_links:
                    for lb in targets:
                        pts += [
                            c
                            for c in bl.closest(body, other, TOUCH, link_a=ln, link_b=lb)
                            if c.distance <= TOUCH
                        ]
            self._static = _dedupe(self._contact(c) for c in pts)
            self._static_version = self.table.version
        return self._static

    def contacts(self, clearance: float = TOUCH) -> list[Contact]:
        """Every contact at the robot's current state, one per pair (deepest), deepest first; other bodies
        closer than ``clearance`` (m) count as contacts (self-contacts at distance <= 0 only)."""
        bl = self.robot.bullet
        bl.detect()
        raw, asked = [], set()
        for c in bl.contacts_raw(self.robot.body):  # as ``is_free``: the points ``Recheck`` confirms
            within = TOUCH if c[1] == c[2] else clearance
            if not self.recheck.asks(c, within) or (c[1] == c[2]
                                                    and (min(c[3], c[4]), max(c[3], c[4])) in self.filtered):
                continue
            if not self.recheck.stands(c, within):
                if c[1:5] in asked:  # the pair's fresh points are in already
                    continue
                asked.add(c[1:5])
            raw += self.recheck.points(c, within)
        pts = [ContactPoint(c[1], c[2], c[3], c[4], tuple(c[5]), float(c[8])) for c in raw]
        if self.massless_moving:
            pts += self._closest_links(self.massless_moving, clearance)
        if clearance > TOUCH:
            pts += self._near(clearance)
        return _dedupe([*self.static_contacts(), *(self._contact(c) for c in pts)])

    def is_free(self, clearance: float = TOUCH, others_apart: bool = False) -> bool:
        """Fast check at the current state (no contact details): no self-contact, and no other body
        closer than ``clearance`` (m) to a moving link. ``others_apart``: the caller knows that every
        other body is farther than ``clearance`` (see `gap`), so no distance query is made."""
        if self.static_contacts():
            return False
        bl = self.robot.bullet
        bl.detect()
        body = self.robot.body
        for c in bl.contacts_raw(body):  # a point within RECHECK confirmed by its pair's test (Recheck)
            if c[1] != c[2]:
                if self.recheck.touching(c, clearance):
                    return False
            elif (min(c[3], c[4]), max(c[3], c[4])) not in self.filtered and self.recheck.touching(c, TOUCH):
                return False
        if others_apart:
            return True
        if self.massless_moving and self._closest_links(self.massless_moving, clearance):
            return False
        # contacts are reported for touching shapes only: a gap below the clearance needs distance queries,
        # asked only of the bodies whose boxes come that close to a moving link
        return clearance <= TOUCH or not self._within(clearance)

    def gap(self, cap: float) -> float:
        """The distance (m) from the moving links to the nearest other body, or ``cap`` when none is
        closer (``inf`` when the world holds no other body). Distance queries as in `is_free`, so
        ``gap(cap) <= c`` exactly when ``is_free(c)`` finds another body within ``c`` (for c <= cap)."""
        if not self._others():
            return float("inf")
        return min((c.distance for c in self._near(cap)), default=cap)

    def _within(self, clearance: float) -> bool:
        """Another body closer than ``clearance`` (m) to a moving link."""
        return bool(self._near(clearance, first=True))

    def _near(self, clearance: float, first: bool = False) -> list[ContactPoint]:
        """Points of other bodies closer than ``clearance`` (m) to a moving link (distance queries, asked
        only of the bodies whose boxes come that close); just the first one found with ``first``."""
        bl, body = self.robot.bullet, self.robot.body
        moving = set(self.robot.moving_links)
        out: list[ContactPoint] = []
        near = bl.bodies_near_links(body, self.robot.moving_links, clearance) & set(self._others())
        for other in sorted(near):
            for c in bl.closest(body, other, clearance):
                if c.distance <= clearance and c.link_a in moving:
                    out.append(c)
                    if first:
                        return out
        return out

    def batch(self, qs: FloatArray, progress: Callable[[int], None] | None = None) -> np.ndarray:
        """Collision-free flag per row of ``qs`` (validated by the caller); restores the robot state. A
        row's flag does not depend on what was checked before it (``is_free``: the contacts Bullet kept
        from an earlier test confirmed by the pair's own, ``client.Recheck``); the batch also starts
        by a test at the robot's state, not at whatever row another batch ended with."""
        robot = self.robot
        saved = robot.q.copy()
        out = np.zeros(len(qs), dtype=bool)
        if self.static_contacts():
            return out
        robot.bullet.detect()
        try:
            for i, q in enumerate(qs):
                robot.apply(q)
                out[i] = self.is_free()
                if progress is not None and (i + 1) % 1000 == 0:
                    progress(i + 1)
        finally:
            robot.apply(saved)
        return out


def _dedupe(contacts: Iterable[Contact]) -> list[Contact]:
    best: dict[tuple[str, str | None, str, str | None], Contact] = {}
    for c in contacts:
        k1 = (c.a.body, c.a.link, c.b.body, c.b.link)
        k2 = (c.b.body, c.b.link, c.a.body, c.a.link)
        key = k2 if k2 in best else k1
        if key not in best or c.depth > best[key].depth:
            best[key] = c
    return sorted(best.values(), key=lambda c: -c.depth)
