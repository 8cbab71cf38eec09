"""Outer bounds: configurations whose collision-freedom is certain from geometry alone, found in numpy for
a whole batch, so that Bullet checks only the others (the other side of ``surehit.py``).

How: every link with collision shapes gets one box in its URDF link frame that holds every vertex of
every convex part Bullet holds for it (decomposed mesh parts, primitives: a box's or cylinder's corners,
a sphere's cube), oriented along the principal axes of those vertices; it holds their convex hull too.
The box is grown by ``GROW`` (Bullet's collision margins: a convex hull is inflated by its margin;
rounding). Every other body is a box as well: primitive obstacles exactly (a sphere or cylinder by the
box around it), mesh obstacles and the links of other robots (which stand still during a check) by their
Bullet bounding boxes. The separating-axis test (15 axes) on two boxes is exact: boxes it separates do
not touch. A configuration is

- apart from every other body (`OuterBounds.apart`) when each moving link's box, grown by ``margin``
  (the clearance a path check keeps; 0 for labels), is separated from every other body's box: Bullet
  reports no contact with them, nor a body within the margin;
- free of self-contact (`OuterBounds.self_free`) when the boxes of every link pair Bullet checks
  (neither the other's parent, not a filtered pair) are separated.

A row apart from every other body needs Bullet only for its self-contact, checked in a world holding the
robot alone (a fraction of a check among hundreds of obstacles); a row free both ways needs no Bullet.
Candidates are found by world-aligned boxes first (a link's box turned into the world), so the
separating-axis test runs only for the rows and bodies whose aligned boxes overlap.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robwot_sim.model.fk import ChainFK, chain_frames
from robwot_sim.model.meshcheck import mesh_points
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.types import FloatArray

GROW = 0.005  # m added to every link box's half extents
CHUNK = 2048  # rows tested at once against the other bodies (bounds the (rows, bodies) arrays)
#: rows of a batch tested first: below MIN_APART rows apart from the other bodies (MIN_RATE free of
#: self-contact) among them, the rest is not tested, for a test that does not pay
PROBE = 500
MIN_APART, MIN_RATE = 0.5, 0.05

BoolArray = npt.NDArray[np.bool_]


@dataclass(frozen=True)
class Box:
    """A box: ``centre`` (3,), ``axes`` (3, 3) with the box's axes as columns, ``half`` extents (3,)."""

    centre: FloatArray
    axes: FloatArray
    half: FloatArray


def _shape_points(body: int, link: int, cid: int, shape: Any) -> FloatArray | None:
    """Points whose convex hull holds one collision shape of a link, in its shape frame (None: unknown)."""
    kind, dims, name = shape[2], shape[3], shape[4]
    if kind == pb.GEOM_MESH:
        path = Path(name.decode(errors="replace") if isinstance(name, bytes) else str(name))
        pts = mesh_points(path) if path.is_file() else None
        return None if pts is None or not len(pts) else pts * np.asarray(dims, dtype=np.float64)
    if kind == pb.GEOM_BOX:
        h = np.asarray(dims[:3], dtype=np.float64) / 2
    elif kind == pb.GEOM_SPHERE:
        h = np.full(3, float(dims[0]))
    elif kind in (pb.GEOM_CYLINDER, pb.GEOM_CAPSULE):
        length, radius = float(dims[0]), float(dims[1])
        h = np.array([radius, radius, length / 2 + (radius if kind == pb.GEOM_CAPSULE else 0.0)])
    else:
        return None
    return np.array([[x, y, z] for x in (-h[0], h[0]) for y in (-h[1], h[1]) for z in (-h[2], h[2])])


def link_points(cid: int, body: int, link: int) -> FloatArray | None:
    """Points whose convex hull holds every collision shape of a link as Bullet holds it, in its URDF link
    frame (the fixed base's: in the world frame); None when a shape cannot be read."""
    if link >= 0:
        state = pb.getLinkState(body, link, physicsClientId=cid)
        com_p, com_r = np.asarray(state[2], dtype=np.float64), quat_matrix(state[3])
    else:  # Bullet's base frame is its inertial frame
        pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
        com_p, com_r = np.asarray(pos, dtype=np.float64), quat_matrix(orn)
    shapes = pb.getCollisionShapeData(body, link, physicsClientId=cid) or ()
    out = []
    for k, shape in enumerate(shapes):
        if shape[2] == pb.GEOM_MESH and shape[4] == b"unknown_file":
            # a URDF cylinder Bullet turned into a hull: its vertices as Bullet holds them, placed in the
            # inertial frame already
            _, vertices = pb.getMeshData(body, link, collisionShapeIndex=k, physicsClientId=cid)
            if not vertices:
                return None
            local = np.asarray(vertices, dtype=np.float64)
        else:
            pts = _shape_points(body, link, cid, shape)
            if pts is None:
                return None
            local = np.asarray(shape[5], dtype=np.float64) + pts @ quat_matrix(shape[6]).T
        out.append(com_p + local @ com_r.T)  # inertial frame -> link frame
    return np.concatenate(out) if out else None


def fit_box(points: FloatArray, grow: float) -> Box:
    """The smaller of the boxes along the principal axes of ``points`` and along the link frame's axes
    holding them all (principal axes of a round part point anywhere), half extents grown by ``grow``."""
    centre = points.mean(axis=0)
    best: Box | None = None
    candidates = [np.eye(3)]
    if len(points) > 1:
        principal = np.linalg.svd(points - centre, full_matrices=False)[2]
        candidates.append(np.asarray(principal, dtype=np.float64).T)
    for axes in candidates:
        local = points @ axes
        lo, hi = local.min(axis=0), local.max(axis=0)
        box = Box(axes @ ((lo + hi) / 2), axes, (hi - lo) / 2 + grow)
        if best is None or float(np.prod(box.half)) < float(np.prod(best.half)):
            best = box
    assert best is not None
    return best


def spec_box(spec: dict[str, Any]) -> Box:
    """The box of a primitive obstacle spec (a sphere or cylinder: the box around it)."""
    s = spec["shape"]
    if s["type"] == "box":
        half = np.asarray(s["size"], dtype=np.float64) / 2
    elif s["type"] == "sphere":
        half = np.full(3, float(s["radius"]))
    else:
        half = np.array([float(s["radius"]), float(s["radius"]), float(s["length"]) / 2])
    return Box(np.asarray(spec["position"], dtype=np.float64), quat_matrix(spec["orientation"]), half)


def aabb_box(lo: Any, hi: Any) -> Box:
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return Box((lo + hi) / 2, np.eye(3), (hi - lo) / 2)


def separated(ca: FloatArray, ra: FloatArray, ha: FloatArray, cb: FloatArray, rb: FloatArray,
              hb: FloatArray) -> BoolArray:
    """Per row: boxes (centre (n, 3), axes as columns (n, 3, 3), half extents (n, 3)) A and B apart, by
    the separating-axis test (their faces' 6 normals and the 9 cross products of their edges)."""
    r = np.einsum("nki,nkj->nij", ra, rb)  # B's axes in A's frame
    t = np.einsum("nki,nk->ni", ra, cb - ca)  # B's centre in A's frame
    ar = np.abs(r) + 1e-9
    out = (np.abs(t) > ha + np.einsum("nij,nj->ni", ar, hb)).any(axis=1)
    out |= (np.abs(np.einsum("ni,nij->nj", t, r)) > np.einsum("ni,nij->nj", ha, ar) + hb).any(axis=1)
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            lhs = np.abs(t[:, i2] * r[:, i1, j] - t[:, i1] * r[:, i2, j])
            rhs = (ha[:, i1] * ar[:, i2, j] + ha[:, i2] * ar[:, i1, j]
                   + hb[:, j1] * ar[:, i, j2] + hb[:, j2] * ar[:, i, j1])
            out |= lhs > rhs
    return np.asarray(out, dtype=bool)


class OuterBounds:
    """The free-for-sure tests of one robot (module docstring): ``boxes[i]`` of link ``links[i]`` in its
    link frame, ``fks[i]`` giving that frame from a joint vector, ``moving[i]`` whether it moves;
    ``pairs`` the self pairs Bullet checks (indices into ``boxes``); ``others`` every other body's box."""

    def __init__(self, boxes: list[Box], fks: list[ChainFK], moving: list[bool], pairs: list[tuple[int, int]],
                 others: list[Box]) -> None:
        self.boxes, self.fks, self.moving, self.pairs = boxes, fks, moving, pairs
        self.other_centre = np.array([o.centre for o in others], dtype=np.float64).reshape(-1, 3)
        self.other_axes = np.array([o.axes for o in others], dtype=np.float64).reshape(-1, 3, 3)
        self.other_half = np.array([o.half for o in others], dtype=np.float64).reshape(-1, 3)
        extent = np.einsum("oij,oj->oi", np.abs(self.other_axes), self.other_half)
        self.other_lo, self.other_hi = self.other_centre - extent, self.other_centre + extent

    @property
    def empty(self) -> bool:
        return not self.boxes

    def _world(self, qs: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
        """Each link box's centre (n, 3) and axes (n, 3, 3) in the world."""
        return [(p + r @ b.centre, r @ b.axes) for (p, r), b in zip(chain_frames(self.fks, qs), self.boxes,
                                                                    strict=True)]

    def apart(self, qs: FloatArray, margin: float = 0.0, probe: bool = True) -> BoolArray:
        """True where every moving link of the configuration (row of ``qs``, validated) keeps more than
        ``margin`` (m) from every other body, for sure (self-contact not tested). Empty bounds: never.
        With ``probe``, when fewer than ``MIN_APART`` of the first ``PROBE`` rows are (a scene crowding the
        robot), the other rows are left to Bullet."""
        n = len(qs)
        if self.empty or n == 0:
            return np.zeros(n, dtype=bool)
        ok = np.ones(n, dtype=bool)
        if not len(self.other_centre):
            return ok
        starts = [0, *range(PROBE, n, CHUNK)] if probe and n > PROBE else list(range(0, n, CHUNK))
        for lo, hi in zip(starts, [*starts[1:], n], strict=True):
            ok[lo:hi] = self._apart(qs[lo:hi], margin)
            if probe and lo == 0 and hi < n and ok[:hi].mean() < MIN_APART:
                ok[hi:] = False
                break
        return ok

    def _apart(self, qs: FloatArray, margin: float) -> BoolArray:
        ok = np.ones(len(qs), dtype=bool)
        for k, (centre, axes) in enumerate(self._world(qs)):
            if not self.moving[k]:
                continue
            half = self.boxes[k].half + margin
            extent = np.einsum("nij,j->ni", np.abs(axes), half)
            lo, hi = centre - extent, centre + extent
            overlap = ((lo[:, None, :] <= self.other_hi[None])
                       & (hi[:, None, :] >= self.other_lo[None])).all(axis=2)
            rows, which = np.nonzero(overlap & ok[:, None])
            if not len(rows):
                continue
            apart = separated(centre[rows], axes[rows], np.broadcast_to(half, (len(rows), 3)),
                              self.other_centre[which], self.other_axes[which], self.other_half[which])
            ok[rows[~apart]] = False
        return ok

    def self_free(self, qs: FloatArray, probe: bool = True) -> BoolArray:
        """True where no self pair Bullet checks can touch in the configuration (row of ``qs``), for sure.
        With ``probe``, when fewer than ``MIN_RATE`` of the first ``PROBE`` rows are (a robot whose links
        nest too closely for boxes), the other rows are left to Bullet."""
        if not probe or len(qs) <= PROBE:
            return self._self_free(qs)
        first = self._self_free(qs[:PROBE])
        if first.mean() < MIN_RATE:
            return np.concatenate([first, np.zeros(len(qs) - PROBE, dtype=bool)])
        return np.concatenate([first, self._self_free(qs[PROBE:])])

    def _self_free(self, qs: FloatArray) -> BoolArray:
        n = len(qs)
        if self.empty or n == 0:
            return np.zeros(n, dtype=bool)
        ok = np.ones(n, dtype=bool)
        world = self._world(qs)
        for a, b in self.pairs:
            rows = np.flatnonzero(ok)
            (ca, ra), (cb, rb) = world[a], world[b]
            ha = np.broadcast_to(self.boxes[a].half, (len(rows), 3))
            hb = np.broadcast_to(self.boxes[b].half, (len(rows), 3))
            ok[rows[~separated(ca[rows], ra[rows], ha, cb[rows], rb[rows], hb)]] = False
        return ok


def build_outer_bounds(bound: Any, filtered: set[tuple[int, int]], model: Any,
                       obstacles: list[tuple[int, dict[str, Any]]], others: list[Any]) -> OuterBounds:
    """The free-for-sure tests of a loaded robot (``BoundRobot``, its filtered pairs and ``RobotModel``) in
    a world of ``obstacles`` (body id, spec) and other robots (``BoundRobot``, at their current state).
    Empty (never free for sure) when a link's shapes cannot be read or the FK does not reproduce Bullet's
    link frames to 1e-6 m / 1e-6."""
    cid, body = bound.bullet.cid, bound.body
    never = OuterBounds([], [], [], [], [])
    moving = set(bound.moving_links)
    links = [ln for ln in range(-1, pb.getNumJoints(body, physicsClientId=cid))
             if pb.getCollisionShapeData(body, ln, physicsClientId=cid)]
    points = [link_points(cid, body, ln) for ln in links]
    if any(p is None for p in points):
        return never
    world = ChainFK([], bound.dof, bound.link_names[-1])  # the identity: the base's box is in the world
    fks = [world if ln < 0 else ChainFK.from_joints(
        model.joints, model.links, bound.link_names[ln], model.controllable, model.couplings,
        base_position=model.base_position, base_orientation=model.base_orientation) for ln in links]
    q = np.asarray(bound.q, dtype=np.float64)[None, :]
    for ln, fk in zip(links, fks, strict=True):
        if ln < 0:
            continue
        p, r = fk.poses(q)
        frame = bound.bullet.link_frame(body, ln)
        if (np.abs(p[0] - np.asarray(frame[0])).max() > 1e-6
                or np.abs(r[0] - quat_matrix(frame[1])).max() > 1e-6):
            return never
    parent = {ln: int(pb.getJointInfo(body, ln, physicsClientId=cid)[16]) for ln in links if ln >= 0}
    pairs = [(i, j) for i, a in enumerate(links) for j, b in enumerate(links)
             if i < j and parent.get(a) != b and parent.get(b) != a
             and (min(a, b), max(a, b)) not in filtered]
    boxes = []
    for ob_body, spec in obstacles:
        if spec["shape"]["type"] in ("box", "sphere", "cylinder"):
            boxes.append(spec_box(spec))
        else:
            boxes.append(aabb_box(*pb.getAABB(ob_body, -1, physicsClientId=cid)))
    for other in others:
        for ln in range(-1, pb.getNumJoints(other.body, physicsClientId=cid)):
            if pb.getCollisionShapeData(other.body, ln, physicsClientId=cid):
                boxes.append(aabb_box(*pb.getAABB(other.body, ln, physicsClientId=cid)))
    return OuterBounds([fit_box(p, GROW) for p in points if p is not None], fks,
                       [ln in moving for ln in links], pairs, boxes)
