"""Joint couplings: joints that follow others by a linear rule, as parallel linkages and mimic joints do.

A coupling makes one movable joint (the follower) an affine function of other joints:
``follower = sum(factor * leader) + offset``. A URDF ``<mimic>`` is the one-leader case; ``--couple
"FOLLOWER=EXPR"`` writes any linear combination (``joint_3-joint_2``, ``-0.5*J2+J3+0.1``);
``--keep-level LINK`` derives the coupling that keeps LINK's orientation as it is at the zero
configuration where the joints between the base and LINK turn about parallel axes (a parallelogram arm's
passive joint). A follower may follow followers; ``resolve`` flattens every follower into the leaders'
coordinates (the joints that stay controllable), refusing unknown or fixed joints, a joint coupled twice
and cycles, each named.

Expression grammar (whitespace ignored): terms joined by ``+``/``-``; a term is ``NUMBER``, ``NAME``,
``NUMBER*NAME`` or ``NAME*NUMBER``. A name starts with a letter or ``_`` and may hold letters, digits and
``_ . / :`` (a joint named with ``-`` cannot be written in an expression). Anything else (a product of
two joints, a function, a division by a joint) is not linear and refused.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams
from robwot_sim.limits import value_schema
from robwot_sim.model.rotations import rpy_matrix

#: longest rule text and most terms in one expression (the contract's ``CouplingRule``)
MAX_TEXT = int(value_schema("CouplingRule")["maxLength"])
MAX_TERMS = int(value_schema("CouplingRule")["x-maxTerms"])
#: axes within this of parallel (|cos| of their angle >= 1 - PARALLEL) count as parallel
PARALLEL = 1e-6

_NUMBER = r"(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_TOKEN = re.compile(rf"\s*(?:(?P<num>{_NUMBER})|(?P<name>[A-Za-z_][\w./:]*)|(?P<op>[-+*]))")


@dataclass(frozen=True)
class Coupling:
    """``follower = sum(factor * leader) + offset``; ``source`` says where it came from (``mimic``, ``couple``
    or ``keep-level``)."""

    follower: str
    terms: tuple[tuple[str, float], ...]
    offset: float = 0.0
    source: str = "couple"

    @property
    def expression(self) -> str:
        """The rule as ``--couple`` reads it, e.g. ``joint_4=joint_3-joint_2``."""
        parts: list[str] = []
        for name, factor in self.terms:
            sign = "-" if factor < 0 else "+"
            mag = abs(factor)
            parts.append(f"{sign}{name}" if mag == 1.0 else f"{sign}{mag:.12g}*{name}")
        if self.offset != 0.0 or not parts:
            parts.append(f"{'-' if self.offset < 0 else '+'}{abs(self.offset):.12g}")
        text = "".join(parts)
        return f"{self.follower}={text[1:] if text.startswith('+') else text}"

    def to_json(self) -> dict[str, object]:
        return {"follower": self.follower, "terms": [{"joint": n, "factor": f} for n, f in self.terms],
                "offset": self.offset, "source": self.source, "expression": self.expression}


def _refuse(param: str, reason: str, got: object) -> InvalidParams:
    return InvalidParams(f"invalid param '{param}': {reason}", param=param, expected=reason, got=got)


def parse_coupling(text: str, param: str = "couplings") -> Coupling:
    """``FOLLOWER=EXPR`` read into a coupling; a text that is not such a linear rule is refused naming
    ``param`` and the first thing wrong."""
    if not isinstance(text, str) or len(text) > MAX_TEXT:
        raise _refuse(param, f"a text 'FOLLOWER=EXPR' of at most {MAX_TEXT} characters", text)
    follower, eq, expr = text.partition("=")
    follower = follower.strip()
    if not eq or not re.fullmatch(r"[A-Za-z_][\w./:]*", follower):
        raise _refuse(param, "'FOLLOWER=EXPR' with FOLLOWER a joint name", text)
    terms, offset = _linear(expr, param, text)
    return Coupling(follower, terms, offset)


def _tokens(expr: str, param: str, text: str) -> list[tuple[str, str]]:
    out: list[tuple[str, str]] = []
    pos = 0
    while pos < len(expr.rstrip()):
        m = _TOKEN.match(expr, pos)
        if m is None or m.end() == pos:
            raise _refuse(param, f"a linear expression; cannot read {expr[pos:].strip()[:20]!r}", text)
        kind = next(k for k in ("num", "name", "op") if m.group(k) is not None)
        out.append((kind, m.group(kind)))
        pos = m.end()
    return out


def _linear(expr: str, param: str, text: str) -> tuple[tuple[tuple[str, float], ...], float]:
    """The terms (summed per joint, zeros dropped) and constant of ``expr``."""
    toks = _tokens(expr, param, text)
    if not toks:
        raise _refuse(param, "an expression after '='", text)
    factors: dict[str, float] = {}
    offset, k, count = 0.0, 0, 0
    while k < len(toks):
        sign = 1.0
        while k < len(toks) and toks[k][0] == "op" and toks[k][1] in "+-":
            sign, k = (-sign if toks[k][1] == "-" else sign), k + 1
        if (k == 0 and count) or (count and toks[k - 1][0] != "op"):
            raise _refuse(param, "terms joined by '+' or '-'", text)
        factor, name, k = _term(toks, k, param, text)
        count += 1
        if count > MAX_TERMS:
            raise _refuse(param, f"at most {MAX_TERMS} terms", text)
        if name is None:
            offset += sign * factor
        else:
            factors[name] = factors.get(name, 0.0) + sign * factor
    if not all(math.isfinite(v) for v in (offset, *factors.values())):
        raise _refuse(param, "finite numbers", text)
    return tuple((n, f) for n, f in factors.items() if f != 0.0), offset


def _term(toks: list[tuple[str, str]], k: int, param: str, text: str) -> tuple[float, str | None, int]:
    """One term at ``toks[k]``: its factor, its joint (None for a constant) and the index after it."""
    if k >= len(toks) or toks[k][0] == "op":
        raise _refuse(param, "a number or a joint name after each sign", text)
    first = toks[k]
    k += 1
    if k < len(toks) and toks[k] == ("op", "*"):
        if k + 1 >= len(toks) or toks[k + 1][0] == "op" or toks[k + 1][0] == first[0]:
            raise _refuse(param, "a linear expression: a '*' joins one number and one joint", text)
        second = toks[k + 1]
        k += 2
        num, name = (first[1], second[1]) if first[0] == "num" else (second[1], first[1])
        return float(num), name, k
    return (float(first[1]), None, k) if first[0] == "num" else (1.0, first[1], k)


class UrdfJoint(Protocol):
    """What this module reads of a URDF joint (``model/joints.py``'s ``JointInfo``, which imports this
    module and so cannot be imported here)."""

    @property
    def name(self) -> str: ...
    @property
    def type(self) -> str: ...
    @property
    def parent(self) -> str: ...
    @property
    def child(self) -> str: ...
    @property
    def origin_rpy(self) -> tuple[float, float, float]: ...
    @property
    def axis(self) -> tuple[float, float, float]: ...
    @property
    def lower(self) -> float: ...
    @property
    def upper(self) -> float: ...
    @property
    def velocity(self) -> float: ...


def resolve(couplings: Sequence[Coupling], joints: Sequence[UrdfJoint]) -> tuple[Coupling, ...]:
    """Every follower written in the leaders' coordinates (followers of followers substituted), in URDF
    joint order. A later coupling of a follower given twice is refused, as are unknown or fixed joints and
    cycles; at least one joint stays a leader."""
    movable = {j.name for j in joints if j.type != "fixed"}
    known = {j.name for j in joints}
    rules: dict[str, Coupling] = {}
    for c in couplings:
        for name in (c.follower, *(n for n, _ in c.terms)):
            if name not in known:
                raise _refuse("couplings", f"{c.expression!r} names {name!r}, which the robot "
                                           "does not have", c.expression)
            if name not in movable:
                raise _refuse("couplings", f"{c.expression!r} names the fixed joint {name!r}",
                              c.expression)
        if c.follower in rules:
            raise _refuse("couplings", f"{c.follower!r} is coupled twice "
                                       f"({rules[c.follower].expression!r}, {c.expression!r})", c.expression)
        rules[c.follower] = c
    if rules and movable <= rules.keys():
        raise _refuse("couplings", "every movable joint would follow another: none is left to control",
                      [c.expression for c in couplings])
    flat: dict[str, Coupling] = {}
    for follower in rules:
        _flatten(follower, rules, flat, [])
    return tuple(flat[j.name] for j in joints if j.name in flat)


def _flatten(name: str, rules: Mapping[str, Coupling], flat: dict[str, Coupling],
             path: list[str]) -> Coupling:
    if name in flat:
        return flat[name]
    if name in path:
        cycle = " -> ".join([*path[path.index(name):], name])
        raise _refuse("couplings", f"the rules form a cycle: {cycle}", cycle)
    rule = rules[name]
    factors: dict[str, float] = {}
    offset = rule.offset
    for leader, factor in rule.terms:
        if leader in rules:
            inner = _flatten(leader, rules, flat, [*path, name])
            offset += factor * inner.offset
            for n, f in inner.terms:
                factors[n] = factors.get(n, 0.0) + factor * f
        else:
            factors[leader] = factors.get(leader, 0.0) + factor
    out = Coupling(name, tuple((n, f) for n, f in factors.items() if f != 0.0), offset, rule.source)
    flat[name] = out
    return out


def chain_to(link: str, joints: Sequence[UrdfJoint]) -> list[UrdfJoint]:
    """The joints from the root link down to ``link``, root first (empty for the root)."""
    by_child = {j.child: j for j in joints}
    chain: list[UrdfJoint] = []
    while link in by_child:
        chain.append(by_child[link])
        link = by_child[link].parent
    return chain[::-1]


def keep_level(link: str, joints: Sequence[UrdfJoint], followers: Iterable[str] = ()) -> Coupling:
    """The coupling that keeps ``link``'s orientation as at the zero configuration: the joints between
    the base and ``link`` that tilt it (revolute axes not along the root's vertical) must all turn about
    one axis and come after every vertical one; the last of them not already a follower follows the
    others (``sum(sign * q) = 0`` with ``sign`` the direction of each axis along the common one)."""
    chain = chain_to(link, joints)
    if not chain:
        raise _refuse("keepLevel", f"{link!r} is the root link or not a link of the robot", link)
    rot = np.eye(3)
    tilting: list[tuple[UrdfJoint, np.ndarray]] = []
    for j in chain:
        rot = rot @ rpy_matrix(*j.origin_rpy)
        if j.type not in ("revolute", "continuous"):
            continue
        axis = rot @ np.asarray(j.axis, dtype=np.float64)
        if abs(abs(axis[2]) - 1.0) <= PARALLEL:
            if tilting:
                raise _refuse("keepLevel", f"{j.name!r} turns about the vertical "
                                           f"after {tilting[-1][0].name!r} tilts, so {link!r} cannot be kept "
                                           "level by a linear coupling", link)
            continue
        if tilting and abs(abs(float(axis @ tilting[0][1])) - 1.0) > PARALLEL:
            raise _refuse("keepLevel", f"{j.name!r} and {tilting[0][0].name!r} turn "
                                       f"about different axes, so {link!r} cannot be kept level by a linear "
                                       "coupling", link)
        tilting.append((j, axis))
    return _level_rule(link, tilting, set(followers))


def _level_rule(link: str, tilting: list[tuple[UrdfJoint, np.ndarray]], followers: set[str]) -> Coupling:
    free = [j for j, _ in tilting if j.name not in followers]
    if len(tilting) < 2 or not free:
        raise _refuse("keepLevel", f"keeping {link!r} level needs two or more tilting joints above it, one "
                                   f"of them not yet coupled; it has {[j.name for j, _ in tilting]}", link)
    ref = tilting[0][1]
    sign = {j.name: (1.0 if float(axis @ ref) > 0 else -1.0) for j, axis in tilting}
    follower = free[-1].name
    terms = tuple((j.name, -sign[j.name] / sign[follower]) for j, _ in tilting if j.name != follower)
    return Coupling(follower, terms, 0.0, "keep-level")


def passive_hints(joints: Sequence[UrdfJoint], velocity: Mapping[str, float],
                  transmitted: set[str], origins: Mapping[str, tuple[float, ...]],
                  coupled: set[str]) -> list[tuple[str, str]]:
    """Movable joints that look passive, each with why, skipping those already coupled: a velocity limit
    of 0 where other joints have one (``velocity`` holds the limits the URDF states; a joint it lacks
    states none, as a continuous joint without ``<limit>``, and is not suspect), no ``<transmission>``
    where other joints have one, or a parent and origin shared with another movable joint (parallelogram
    bars hinge side by side)."""
    movable = [j for j in joints if j.type != "fixed"]
    some_speed = any(velocity.get(j.name, 0.0) > 0 for j in movable)
    seen: dict[tuple[str, tuple[float, ...]], str] = {}
    why: dict[str, list[str]] = {}
    for j in movable:
        reasons = why.setdefault(j.name, [])
        if some_speed and velocity.get(j.name, 1.0) <= 0:
            reasons.append("its velocity limit is 0 where other joints have one")
        if transmitted and j.name not in transmitted:
            reasons.append("it has no <transmission> where other joints have one")
        key = (j.parent, tuple(round(v, 6) for v in origins.get(j.name, ())))
        if key in seen:
            reasons.append(f"it hinges at the same point of {j.parent!r} as {seen[key]!r}, as the bars of a "
                           "parallel linkage do")
        else:
            seen[key] = j.name
    return [(name, "; ".join(r)) for name, r in why.items() if r and name not in coupled]


@dataclass(frozen=True)
class Followers:
    """The followers of a robot as arrays over its joint vector: ``values(q) = q @ matrix.T + offset``, one
    column per follower in ``names`` order, each within ``[lower, upper]`` (continuous ones unbounded)."""

    names: tuple[str, ...]
    matrix: npt.NDArray[np.float64]
    offset: npt.NDArray[np.float64]
    lower: npt.NDArray[np.float64]
    upper: npt.NDArray[np.float64]
    #: velocity limit per follower (rad/s or m/s); 0 where the URDF gives none (a passive joint)
    velocity: npt.NDArray[np.float64]

    @classmethod
    def of(cls, controllable: Sequence[str], couplings: Sequence[Coupling],
           joints: Sequence[UrdfJoint]) -> Followers:
        """The followers of ``couplings`` over the joint vector ``controllable``, limits from ``joints``
        (a continuous joint is unbounded)."""
        limits = {j.name: (j.lower, j.upper, j.velocity) if j.type != "continuous"
                  else (1.0, -1.0, j.velocity) for j in joints}
        index = {n: i for i, n in enumerate(controllable)}
        matrix = np.zeros((len(couplings), len(controllable)))
        for row, c in enumerate(couplings):
            for name, factor in c.terms:
                matrix[row, index[name]] += factor
        lo, hi, vel = (np.array([limits[c.follower][k] for c in couplings], dtype=np.float64)
                       for k in range(3))
        unbounded = lo > hi
        return cls(tuple(c.follower for c in couplings), matrix,
                   np.array([c.offset for c in couplings], dtype=np.float64),
                   np.where(unbounded, -np.inf, lo), np.where(unbounded, np.inf, hi), vel)

    def __len__(self) -> int:
        return len(self.names)

    def values(self, qs: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """Follower values ``(n, followers)`` of joint vectors ``(n, dof)`` (or ``(followers,)`` of one)."""
        q = np.asarray(qs, dtype=np.float64)
        out: npt.NDArray[np.float64] = q @ self.matrix.T + self.offset
        return out

    def within(self, qs: npt.ArrayLike, tolerance: float = 0.0) -> npt.NDArray[np.bool_]:
        """Per joint vector: every follower within its limits (``tolerance`` beyond them allowed)."""
        v = self.values(np.atleast_2d(np.asarray(qs, dtype=np.float64)))
        inside = (v >= self.lower - tolerance) & (v <= self.upper + tolerance)
        ok: npt.NDArray[np.bool_] = np.all(inside, axis=1)
        return ok

    def first_violation(self, q: npt.ArrayLike,
                        tolerance: float = 0.0) -> tuple[str, float, float, float] | None:
        """The first follower of joint vector ``q`` past a limit: (name, value, lower, upper), or None."""
        v = self.values(q)
        for k, name in enumerate(self.names):
            if not self.lower[k] - tolerance <= v[k] <= self.upper[k] + tolerance:
                return name, float(v[k]), float(self.lower[k]), float(self.upper[k])
        return None


def passive_notes(file: str, joints: Sequence[UrdfJoint], velocity: Mapping[str, float],
                  origins: Mapping[str, tuple[float, ...]], transmitted: set[str],
                  coupled: set[str]) -> list[str]:
    """One line per joint that looks passive (``passive_hints``) and is not coupled: what the user can do
    about it. Nothing is guessed: such a joint stays controllable until a rule says otherwise."""
    return [f"{file}: joint {name!r} looks passive ({why}): if a linkage drives it, give --keep-level LINK "
            f"(the link it keeps level) or --couple \"{name}=EXPR\"; it is served as a controllable joint"
            for name, why in passive_hints(joints, velocity, transmitted, origins, coupled)]
