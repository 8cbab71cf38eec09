"""Vectorised forward kinematics (numpy) of the joint chain from a URDF's root link to one link.

Frames: the world frame (Z up). The robot's root link frame is placed at the base pose given at load
(``base_position`` in m, ``base_orientation`` as ``[x, y, z, w]``); each joint applies its ``<origin>``
(``xyz`` in m, ``rpy`` in rad, fixed-axis roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)) and then its
motion about/along ``<axis>`` (expressed in the joint frame). The result is the URDF link frame of the
target link (not its centre of mass), as ``World.fk`` reports it.

Joint values come in the order of the robot's ``controllable`` list; coupled joints (mimic ones included)
follow their rule in those joints' coordinates; fixed joints only contribute their origin.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import UnknownLink
from robwot_sim.model.couplings import Coupling
from robwot_sim.model.joints import MOVABLE, JointInfo
from robwot_sim.model.rotations import quat_matrix, rpy_matrix

FloatArray = npt.NDArray[np.float64]



@dataclass(frozen=True)
class ChainJoint:
    """One joint on the chain: its value is ``sum(q[i] * factor for i, factor in terms) + offset`` (a
    controllable joint: one term of factor 1; a follower: its coupling; a fixed joint: no term, and it
    does not move)."""

    name: str
    type: str
    origin_xyz: tuple[float, float, float]
    origin_rot: tuple[tuple[float, float, float], ...]
    axis: tuple[float, float, float]
    terms: tuple[tuple[int, float], ...] = ()
    offset: float = 0.0

    @property
    def moves(self) -> bool:
        return self.type in MOVABLE


class ChainFK:
    """Forward kinematics of the chain ending at ``ee_link``, vectorised over configurations."""

    def __init__(self, joints: Sequence[ChainJoint], dof: int, ee_link: str,
                 base_position: Sequence[float] = (0.0, 0.0, 0.0),
                 base_orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> None:
        self.joints = tuple(joints)
        self.dof = dof
        self.ee_link = ee_link
        self.base_position = np.asarray(base_position, dtype=np.float64).reshape(3)
        self.base_rotation = quat_matrix(base_orientation)

    @classmethod
    def from_joints(cls, joints: Sequence[JointInfo], links: Sequence[str], ee_link: str,
                    controllable: Sequence[str], couplings: Sequence[Coupling], *,
                    base_position: Sequence[float] = (0.0, 0.0, 0.0),
                    base_orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> ChainFK:
        """The chain root -> ``ee_link`` of a parsed joint tree (``joints.parse_model``, or a robot model
        holding its joints: a tree, so the walk up from any link ends at the root)."""
        if ee_link not in links:
            raise UnknownLink(ee_link, list(links))
        by_child = {j.child: j for j in joints}
        index = {n: i for i, n in enumerate(controllable)}
        rules = {c.follower: c for c in couplings}
        chain: list[JointInfo] = []
        link = ee_link
        while link in by_child:
            chain.append(by_child[link])
            link = by_child[link].parent
        chain.reverse()
        return cls([chain_joint(j, index, rules) for j in chain], len(controllable), ee_link,
                   base_position, base_orientation)

    def _values(self, qs: FloatArray, j: ChainJoint) -> FloatArray:
        (first, factor), *rest = j.terms or ((0, 0.0),)
        v = qs[:, first] if factor == 1.0 else qs[:, first] * factor
        for i, f in rest:
            v = v + qs[:, i] * f
        return v if j.offset == 0.0 else v + j.offset

    def poses(self, qs: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Positions ``(n, 3)`` (m) and rotation matrices ``(n, 3, 3)`` of the end link, world frame."""
        q = np.asarray(qs, dtype=np.float64)
        if q.ndim != 2 or q.shape[1] != self.dof:
            raise ValueError(f"expected configurations of shape (n, {self.dof}), got {q.shape}")
        return chain_frames([self], q)[0]

    def reach_bounds(self, lower: npt.ArrayLike, upper: npt.ArrayLike, seed: int, samples: int = 10_000,
                     starts: int = 4, iterations: int = 60) -> tuple[FloatArray, FloatArray]:
        """Axis-aligned box (world frame, m) of the end link's positions within the joint limits,
        collisions ignored: of ``samples`` configurations drawn uniformly (seeded, its own: the same box
        for a local and a cluster run), for each of the six directions the ``starts`` farthest that way
        climb further by projected gradient ascent (forward
        differences, step doubled on success and quartered on failure; all 6 x ``starts`` climbs in one
        FK batch per iteration), and the box takes the farthest point found. Samples never reach the
        true extremes (a TD bounded by them refused reachable targets); the climb does, to ~0.1 mm."""
        lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
        qs = np.random.default_rng([seed, 0x5EAC4]).uniform(lo, hi, size=(samples, len(lo)))
        positions = self.positions(qs)
        axis = np.repeat(np.arange(3), 2 * starts)
        sign = np.tile(np.repeat([-1.0, 1.0], starts), 3)
        picks = np.concatenate([np.argsort(-sg * positions[:, ax])[:starts]
                                for ax in range(3) for sg in (-1.0, 1.0)])
        q = qs[picks].copy()
        n, dof, h = len(q), qs.shape[1], 1e-6
        rows, probe_rows = np.arange(n), np.arange(n * dof)
        probe_axis, probe_sign = np.repeat(axis, dof), np.repeat(sign, dof)
        current = sign * self.positions(q)[rows, axis]
        step = np.full(n, 0.2)  # rad (or m) along the normalised gradient
        for _ in range(iterations):
            probe = np.repeat(q, dof, axis=0) + h * np.tile(np.eye(dof), (n, 1))
            moved = probe_sign * self.positions(probe)[probe_rows, probe_axis]
            grad = (moved.reshape(n, dof) - current[:, None]) / h
            norm = np.linalg.norm(grad, axis=1, keepdims=True)
            trial = np.clip(q + step[:, None] * grad / np.maximum(norm, 1e-12), lo, hi)
            got = sign * self.positions(trial)[rows, axis]
            better = got > current
            q[better], current[better] = trial[better], got[better]
            step = np.where(better, step * 2.0, step * 0.25)
            if (step < 1e-6).all():
                break
        box = [positions.min(axis=0).copy(), positions.max(axis=0).copy()]
        for ax, sg, v in zip(axis, sign, current, strict=True):
            side = int(sg > 0)
            box[side][ax] = max(box[side][ax], v) if side else min(box[side][ax], -v)
        return box[0], box[1]

    def positions(self, qs: npt.ArrayLike, block: int = 100_000) -> FloatArray:
        """End-link frame positions ``(n, 3)`` in metres, world frame (in blocks to bound memory)."""
        q = np.asarray(qs, dtype=np.float64)
        if q.ndim != 2 or len(q) <= block:
            return self.poses(q)[0]
        return np.concatenate([self.poses(q[a:a + block])[0] for a in range(0, len(q), block)])


def chain_frames(chains: Sequence[ChainFK], qs: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
    """End-link positions ``(n, 3)`` and rotations ``(n, 3, 3)`` of several chains of one robot (same
    base pose, joint order and URDF, e.g. one per link) for configurations ``qs`` (validated), the
    joints they share computed once."""
    n = len(qs)
    done: dict[str, tuple[FloatArray, FloatArray]] = {}
    out = []
    for fk in chains:
        p: FloatArray = np.broadcast_to(fk.base_position, (n, 3))
        r: FloatArray = np.broadcast_to(fk.base_rotation, (n, 3, 3))
        for j in fk.joints:
            if j.name in done:
                p, r = done[j.name]
                continue
            p = p + r @ np.asarray(j.origin_xyz)
            if j.moves and j.type != "prismatic":
                r = _turn(r, np.asarray(j.origin_rot), np.asarray(j.axis), fk._values(qs, j))
            else:
                r = r @ np.asarray(j.origin_rot)
                if j.moves:
                    p = p + (r @ np.asarray(j.axis)) * fk._values(qs, j)[:, None]
            done[j.name] = (p, r)
        out.append((p, r))
    return out


#: one coordinate over a batch: an array, or a number while no joint has moved it
Column = FloatArray | float


def end_frames(fk: ChainFK, qs: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``fk.poses(qs)`` (``qs`` validated) computed coordinate by coordinate: each rotation entry and
    position coordinate is one array over the batch (a number while no joint has moved it), each 3x3
    product written out with the zero entries of the URDF's origins and axes left out. Its work is a
    fixed number of numpy operations per joint, each over the whole batch: faster than ``poses`` for
    large batches, slower for a few rows. A row's result depends on that row alone (elementwise
    arithmetic), not on the batch it is in, as a generation's files need (``workspace/chunk.py``); it may
    differ from ``poses`` in the last bits."""
    p: list[Column] = [float(v) for v in fk.base_position]
    r: list[list[Column]] = [[float(v) for v in row] for row in fk.base_rotation]
    for j in fk.joints:
        rot = np.asarray(j.origin_rot)
        p = [_sum(zip(r[i], j.origin_xyz, strict=True), p[i]) for i in range(3)]
        if j.moves and j.type != "prismatic":  # r @ rot @ (I + sin K + (1 - cos) K^2), K: the axis's cross
            a = j.axis
            k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
            rk = rot @ k
            rkk = rk @ k
            angle = fk._values(qs, j)
            sin, vers = np.sin(angle), 1.0 - np.cos(angle)
            m = [[_sum(((sin, float(rk[u, v])), (vers, float(rkk[u, v]))), float(rot[u, v]))
                  for v in range(3)] for u in range(3)]
        else:
            m = [[float(v) for v in row] for row in rot]
        r = [[_dot(r[i], [m[0][v], m[1][v], m[2][v]]) for v in range(3)] for i in range(3)]
        if j.moves and j.type == "prismatic":
            d = fk._values(qs, j)
            p = [p[i] + _sum(zip(r[i], j.axis, strict=True)) * d for i in range(3)]
    n = len(qs)
    positions, rotations = np.empty((n, 3)), np.empty((n, 3, 3))
    for i in range(3):
        positions[:, i] = p[i]
        for v in range(3):
            rotations[:, i, v] = r[i][v]
    return positions, rotations


def _sum(terms: Iterable[tuple[Column, float]], start: Column = 0.0) -> Column:
    """``start + sum(x * f)``: terms of factor 0 left out, of factor 1 not multiplied."""
    acc = start
    for x, f in terms:
        if f == 0.0:
            continue
        term = x if f == 1.0 else x * f
        acc = term if isinstance(acc, float) and acc == 0.0 else acc + term
    return acc


def _dot(row: Sequence[Column], col: Sequence[Column]) -> Column:
    """``sum(row[k] * col[k])``, the products with a zero number left out."""
    acc: Column = 0.0
    for x, y in zip(row, col, strict=True):
        if (isinstance(x, float) and x == 0.0) or (isinstance(y, float) and y == 0.0):
            continue
        term = x * y
        acc = term if isinstance(acc, float) and acc == 0.0 else acc + term
    return acc


def _turn(r: FloatArray, origin: FloatArray, axis: FloatArray, angle: FloatArray) -> FloatArray:
    """``r @ origin @ R(axis, angle)`` for rotations ``r`` ``(n, 3, 3)``, ``R`` by Rodrigues
    (``I + sin K + (1 - cos) K^2``): ``r`` times the three constant matrices in one product, then the
    per-row sum (half the time of building every ``R`` and multiplying matrix by matrix)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    ok = origin @ k
    m = np.concatenate([origin, ok, ok @ k], axis=1)  # (3, 9)
    n = len(angle)
    rr = (np.reshape(r, (3 * n, 3)) @ m).reshape(n, 3, 3, 3)
    s = np.sin(angle)[:, None, None]
    c = (1.0 - np.cos(angle))[:, None, None]
    out: FloatArray = rr[:, :, 0] + s * rr[:, :, 1] + c * rr[:, :, 2]
    return out


def chain_joint(j: JointInfo, index: dict[str, int], rules: dict[str, Coupling]) -> ChainJoint:
    """The chain joint of ``j``, driven by the joint vector (``index``) directly or through its coupling
    (``rules``: couplings written in the controllable joints' coordinates)."""
    terms: tuple[tuple[int, float], ...] = ()
    offset = 0.0
    if j.type in MOVABLE:
        if j.name in index:
            terms = ((index[j.name], 1.0),)
        elif j.name in rules:
            terms, offset = tuple((index[n], f) for n, f in rules[j.name].terms), rules[j.name].offset
        else:
            raise ValueError(f"joint {j.name!r} is neither in the joint vector nor coupled to it")
    rot = rpy_matrix(*j.origin_rpy)
    return ChainJoint(j.name, j.type, j.origin_xyz, tuple((float(a), float(b), float(c)) for a, b, c in rot),
                      j.axis, terms, offset)
