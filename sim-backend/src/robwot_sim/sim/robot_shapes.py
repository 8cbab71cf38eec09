"""What the outer bounds (``outerbounds.py``) know of a robot itself, whatever surrounds it, built once per
robot body: its joint tree as the compiled kernels take it, and per link with collision shapes the outer
shapes of its convex parts (a decomposed mesh part, a primitive, a hull Bullet built), in the link's URDF
frame:

- spheres covering each part, for the other bodies: the part is cut into slabs along its principal axis,
  about as long as it is wide, and each slab's piece of the part (its vertices in the slab and the points
  where the part's edges cross the slab's faces: the piece is their convex hull) gets the sphere around it,
  grown by ``GROW`` (Bullet's collision margin, rounding);
- a box (along the part's principal axes or the link's) and a hull of few vertices holding it
  (``decompose.slim``), for the self pairs, and per vertex the part's own point nearest to it (its
  corners), for sure hits where the part's points are its own (``own``: not a sphere's or capsule's,
  whose points are its box's corners), and the planes of the faces and the vertices of its convex hull
  (Bullet's own shape of it): a corner of one part deeper than ``surehit.DEPTH`` inside another's hull is
  a sure hit of their self pair, the hull's distance to another body is exact (``gjk_kernel.py``);
- the balls inside its parts (``surehit.link_balls``), for sure hits.

And per self pair, a table over the joint coordinates that move its links where there are at most two
(``pair_tables.py``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robwot_sim.model.meshcheck import mesh_points
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim import shape_cache
from robwot_sim.sim.joint_tree import Tree, joint_tree, tree_frames
from robwot_sim.sim.pair_tables import PairTables, pair_tables
from robwot_sim.sim.surehit import SELF_BALLS, LinkBalls, link_balls
from robwot_sim.sim.types import FloatArray

#: m added to every sphere's radius: Bullet reports a hull (a mesh part) within its collision margin (1 mm)
#: of another body as touching; 1 mm more for rounding
GROW = 0.002
MAX_SLABS = 6  # spheres per convex part at most
SLABS_PER_WIDTH = 1.0  # slabs per width of a part along its long axis
SLIM = 0.002  # m: how far a part's hull for the self test may lie outside it (fewer vertices)

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


# the kernels' arguments (``sphere_kernel.py`` says what each holds; the joint tree: ``joint_tree.Tree``)
class Shapes(NamedTuple):
    joint: IntArray
    moving: BoolArray
    sphere_first: IntArray
    sphere_end: IntArray
    sphere_c: FloatArray
    sphere_r: FloatArray
    sphere_part: IntArray
    ball_c: FloatArray
    ball_r: FloatArray
    part_first: IntArray
    part_end: IntArray
    box_c: FloatArray
    box_axes: FloatArray
    box_half: FloatArray
    box_r: FloatArray
    vert_first: IntArray
    vert_end: IntArray
    verts: FloatArray
    corners: FloatArray
    hull_first: IntArray
    hull_end: IntArray
    hull: FloatArray
    own: BoolArray
    face_first: IntArray
    face_end: IntArray
    faces: FloatArray
    link_c: FloatArray
    link_r: FloatArray
    pair_a: IntArray
    pair_b: IntArray
    inner_first: IntArray
    inner_end: IntArray
    inner_c: FloatArray
    inner_r: FloatArray
    self_balls: int
    pair_hit: BoolArray


def _shape_points(body: int, link: int, cid: int, shape: Any) -> FloatArray | None:
    """Points whose convex hull holds one collision shape of a link, in its shape frame (None: unknown)."""
    kind, dims, name = shape[2], shape[3], shape[4]
    if kind == pb.GEOM_MESH:
        path = shape_cache.mesh_file(name)
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


class _Unreadable(Exception):
    """A link's collision shapes could not be read as points (``link_parts`` gave None)."""


def link_parts(cid: int, body: int, link: int) -> list[FloatArray] | None:
    """Per collision shape of a link as Bullet holds it, points whose convex hull holds it, in the link's
    URDF frame (the base: in the world frame); None when a shape cannot be read."""
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
    return out


def _enclosing(points: FloatArray) -> tuple[FloatArray, float]:
    """A ball holding ``points``: centred on their bounding box, radius the farthest point."""
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    return centre, float(np.sqrt(((points - centre) ** 2).sum(axis=1)).max())


def part_spheres(points: FloatArray, grow: float) -> list[tuple[FloatArray, float]]:
    """Spheres whose union holds the convex hull of ``points`` (module docstring), radii grown by
    ``grow``."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.unique(np.asarray(points, dtype=np.float64), axis=0)
    centre = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
    axes = np.asarray(vt, dtype=np.float64).T if vt.shape == (3, 3) else np.eye(3)
    local = (pts - centre) @ axes
    extent = np.ptp(local, axis=0)
    width = float(max(extent[1], extent[2]))
    slabs = int(np.clip(np.ceil(SLABS_PER_WIDTH * extent[0] / max(width, 1e-9) - 1e-9), 1, MAX_SLABS))
    try:
        simplices = ConvexHull(local).simplices if slabs > 1 else None
    except (QhullError, ValueError):
        simplices = None
    if simplices is None:
        c, r = _enclosing(pts)
        return [(c, r + grow)]
    edges = np.unique(np.sort(np.concatenate([simplices[:, [0, 1]], simplices[:, [1, 2]],
                                              simplices[:, [0, 2]]]), axis=1), axis=0)
    u, v = local[edges[:, 0]], local[edges[:, 1]]
    cuts = np.linspace(local[:, 0].min(), local[:, 0].max(), slabs + 1)
    crossings = []
    for t in cuts:
        lo, hi = np.minimum(u[:, 0], v[:, 0]), np.maximum(u[:, 0], v[:, 0])
        crossing = (lo < t) & (t < hi)
        a, b = u[crossing], v[crossing]
        crossings.append(a + ((t - a[:, 0]) / (b[:, 0] - a[:, 0]))[:, None] * (b - a))
    out = []
    for k in range(slabs):
        inside = local[(local[:, 0] >= cuts[k]) & (local[:, 0] <= cuts[k + 1])]
        piece = np.vstack([inside, crossings[k], crossings[k + 1]])
        if not len(piece):
            continue
        c, r = _enclosing(piece)
        out.append((centre + axes @ c, r + grow))
    return out


def fit_box(points: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The smaller of the boxes along the principal axes of ``points`` and along the frame's axes holding
    them all (principal axes of a round part point anywhere): centre, axes as columns, half extents."""
    centre = points.mean(axis=0)
    candidates = [np.eye(3)]
    if len(points) > 2:
        principal = np.linalg.svd(points - centre, full_matrices=False)[2]
        candidates.append(np.asarray(principal, dtype=np.float64).T)
    best: tuple[FloatArray, FloatArray, FloatArray] | None = None
    for axes in candidates:
        local = points @ axes
        lo, hi = local.min(axis=0), local.max(axis=0)
        box = (axes @ ((lo + hi) / 2), axes, (hi - lo) / 2)
        if best is None or float(np.prod(box[2])) < float(np.prod(best[2])):
            best = box
    assert best is not None
    return best


def hull_vertices(points: FloatArray) -> FloatArray:
    """Few vertices whose convex hull holds that of ``points`` (``decompose.slim`` at ``SLIM``: facets
    merged and moved out; the exact hull where that fails; all of them when they are flat)."""
    from scipy.spatial import QhullError

    from robwot_sim.model.decompose import slim

    try:
        with np.errstate(divide="ignore", invalid="ignore"):  # a flat part's planes: slim keeps the hull
            return np.ascontiguousarray(slim(np.asarray(points, dtype=np.float64), SLIM)[0], dtype=np.float64)
    except (QhullError, ValueError):
        return np.ascontiguousarray(points, dtype=np.float64)


def hull_points(points: FloatArray) -> FloatArray:
    """The vertices of the convex hull of ``points`` (all of them where Qhull cannot build it: flat)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return np.ascontiguousarray(points[ConvexHull(points).vertices], dtype=np.float64)
    except (QhullError, ValueError):
        return np.ascontiguousarray(points, dtype=np.float64)


def hull_faces(points: FloatArray) -> FloatArray:
    """The planes of the faces of the convex hull of ``points`` (rows: unit outward normal, offset; a point
    x is inside where every ``n . x + offset`` is negative); none where Qhull cannot build it (flat)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return np.ascontiguousarray(ConvexHull(points).equations, dtype=np.float64)
    except (QhullError, ValueError):
        return np.zeros((0, 4))


@dataclass(frozen=True)
class LinkShapes:
    """The outer shapes of one link with collision shapes, in its URDF frame: Bullet link index, whether it
    moves, spheres (centres (k, 3), radii (k,)) for the other bodies, per convex part a box (centres
    (m, 3), axes as columns (m, 3, 3), half extents (m, 3)) and a hull's vertices for its self pairs."""

    link: int
    moving: bool
    centres: FloatArray
    radii: FloatArray
    sphere_part: IntArray
    box_c: FloatArray
    box_axes: FloatArray
    box_half: FloatArray
    verts: list[FloatArray]
    corners: list[FloatArray]
    own: BoolArray
    faces: list[FloatArray]
    hull: list[FloatArray]
    inner_c: FloatArray
    inner_r: FloatArray

    @classmethod
    def of(cls, link: int, moving: bool, parts: list[FloatArray], inner: LinkBalls | None) -> LinkShapes:
        return cls.made(link, moving, fit_link(parts, inner), np.ones(len(parts), dtype=np.bool_))

    @classmethod
    def made(cls, link: int, moving: bool, a: dict[str, Any], own: BoolArray) -> LinkShapes:
        """A link's shapes from the arrays ``fit_link`` makes (or ``shape_cache`` kept); ``own``: per part,
        whether its points are its own (module docstring)."""
        return cls(link, moving, a["centres"], a["radii"], a["sphere_part"], a["box_c"], a["box_axes"],
                   a["box_half"], a["verts"], a["corners"], own, a["faces"], a["hull"], a["inner_c"],
                   a["inner_r"])


def fit_link(parts: list[FloatArray], inner: LinkBalls | None) -> dict[str, Any]:
    """The fitted arrays of a link's ``LinkShapes`` (the class's fields but its link and whether it moves)."""
    from scipy.spatial import cKDTree

    spheres = [(s, k) for k, pts in enumerate(parts) for s in part_spheres(pts, GROW)]
    boxes = [fit_box(pts) for pts in parts]
    verts = [hull_vertices(pts) for pts in parts]
    return {"centres": np.array([c for (c, _), _ in spheres]).reshape(-1, 3),
            "radii": np.array([r for (_, r), _ in spheres], dtype=np.float64),
            "sphere_part": np.array([k for _, k in spheres], dtype=np.int64),
            "box_c": np.array([b[0] for b in boxes]).reshape(-1, 3),
            "box_axes": np.array([b[1] for b in boxes]).reshape(-1, 3, 3),
            "box_half": np.array([b[2] for b in boxes]).reshape(-1, 3), "verts": verts,
            "corners": [pts[cKDTree(pts).query(v)[1]] for pts, v in zip(parts, verts, strict=True)],
            "faces": [hull_faces(pts) for pts in parts], "hull": [hull_points(pts) for pts in parts],
            "inner_c": np.zeros((0, 3)) if inner is None else inner.centres,
            "inner_r": np.zeros(0) if inner is None else inner.radii}


def _spans(counts: list[int]) -> tuple[IntArray, IntArray]:
    """First and end indices of consecutive runs of ``counts`` items."""
    end = np.cumsum(counts, dtype=np.int64)
    return end - np.asarray(counts, dtype=np.int64), end


def ball(centres: FloatArray, radii: FloatArray) -> tuple[FloatArray, float]:
    """A ball holding balls (``centres``, ``radii``): about their mean centre."""
    if not len(radii):
        return np.zeros(3), 0.0
    c = centres.mean(axis=0)
    return c, float((np.linalg.norm(centres - c, axis=1) + radii).max())


def shapes_of(links: list[LinkShapes], joints: list[int], pairs: list[tuple[int, int]],
              hit_pairs: list[tuple[int, int]]) -> Shapes:
    """The kernel's arrays of the links' shapes (``sphere_kernel.Shapes``), link ``l`` in frame
    ``joints[l]``."""
    inner_first, inner_end = _spans([len(lk.inner_r) for lk in links])
    sphere_first, sphere_end = _spans([len(lk.radii) for lk in links])
    part_first, part_end = _spans([len(lk.box_half) for lk in links])
    verts = [v for lk in links for v in lk.verts]
    vert_first, vert_end = _spans([len(v) for v in verts])
    faces = [f for lk in links for f in lk.faces]
    hulls = [h for lk in links for h in lk.hull]
    hull_first, hull_end = _spans([len(h) for h in hulls])
    hits = set(hit_pairs)
    face_first, face_end = _spans([len(f) for f in faces])
    balls = [ball(lk.centres, lk.radii) for lk in links]
    parts = [ball(lk.box_c, np.array([np.linalg.norm(v - c, axis=1).max() if len(v) else 0.0
                                       for v, c in zip(lk.verts, lk.box_c, strict=True)]))
             for lk in links]

    def cat(arrays: list[FloatArray], shape: tuple[int, ...]) -> FloatArray:
        return np.concatenate(arrays) if arrays else np.zeros(shape)

    box_half = cat([lk.box_half for lk in links], (0, 3))
    box_c = cat([lk.box_c for lk in links], (0, 3))
    # a part's ball: about its box's centre, out to its hull's farthest vertex (inside the box's corners)
    box_r = np.array([float(np.linalg.norm(v - c, axis=1).max()) if len(v) else 0.0
                      for v, c in zip(verts, box_c, strict=True)])
    return Shapes(np.array(joints, dtype=np.int64), np.array([lk.moving for lk in links], dtype=np.bool_),
                  sphere_first, sphere_end, cat([lk.centres for lk in links], (0, 3)),
                  cat([lk.radii for lk in links], (0,)),
                  np.concatenate([lk.sphere_part + first for lk, first in zip(links, part_first, strict=True)]
                                 ) if links else np.zeros(0, dtype=np.int64),
                  np.array([c for c, _ in balls]).reshape(-1, 3),
                  np.array([r for _, r in balls], dtype=np.float64),
                  part_first, part_end, box_c, cat([lk.box_axes for lk in links], (0, 3, 3)), box_half, box_r,
                  vert_first, vert_end, cat(verts, (0, 3)),
                  cat([c for lk in links for c in lk.corners], (0, 3)),
                  hull_first, hull_end, cat(hulls, (0, 3)),
                  np.concatenate([lk.own for lk in links]) if links else np.zeros(0, dtype=np.bool_),
                  face_first, face_end, cat(faces, (0, 4)),
                  np.array([c for c, _ in parts]).reshape(-1, 3),
                  np.array([r for _, r in parts], dtype=np.float64),
                  np.array([a for a, _ in pairs], dtype=np.int64),
                  np.array([b for _, b in pairs], dtype=np.int64),
                  inner_first, inner_end, cat([lk.inner_c for lk in links], (0, 3)),
                  cat([lk.inner_r for lk in links], (0,)), SELF_BALLS,
                  np.array([pair in hits for pair in pairs], dtype=np.bool_))


@dataclass(frozen=True)
class RobotShapes:
    """What the outer bounds know of a robot itself, whatever surrounds it: its joint tree, the shapes of
    its links with collision shapes (``links``), the self pairs Bullet checks (``pairs``, indices into
    ``links``), the kernel's arrays of them and how far from its base any sphere can reach (None: not
    bounded, a prismatic joint)."""

    tree: Tree
    links: tuple[LinkShapes, ...]
    pairs: tuple[tuple[int, int], ...]
    shapes: Shapes
    reach: float | None
    tables: PairTables


def _reach(tree: Tree, links: list[LinkShapes], joints: list[int]) -> float | None:
    """How far (m) from the root's origin any sphere can reach (None with a prismatic joint)."""
    if (tree.kind == 2).any():
        return None
    length = np.zeros(len(tree.parent) + 1)
    for j, p in enumerate(tree.parent):
        length[j] = length[p] + float(np.linalg.norm(tree.origin_p[j]))  # p = -1: the root's 0
    return max((float(length[j] + (np.linalg.norm(lk.centres, axis=1) + lk.radii).max())
                for lk, j in zip(links, joints, strict=True) if len(lk.radii)), default=0.0)


def robot_shapes(bound: Any, filtered: set[tuple[int, int]], model: Any) -> RobotShapes | None:
    """The outer bounds' knowledge of a loaded robot (``BoundRobot``, its filtered pairs and ``RobotModel``),
    built once per robot body. None when a link's shapes cannot be read, a joint is of a kind the kernel
    does not move, or its FK does not reproduce Bullet's link frames to 1e-6 m / 1e-6."""
    cid, body = bound.bullet.cid, bound.body
    made = joint_tree(list(model.joints), list(model.controllable), list(model.couplings),
                      model.base_position, model.base_orientation)
    if made is None:
        return None
    tree, joint_of = made
    moving = set(bound.moving_links)
    links = [ln for ln in range(-1, pb.getNumJoints(body, physicsClientId=cid))
             if pb.getCollisionShapeData(body, ln, physicsClientId=cid)]
    p, r = tree_frames(tree, np.asarray(bound.q, dtype=np.float64))
    joints, shapes = [], []
    for ln in links:
        j = -1 if ln < 0 else joint_of.get(bound.link_names[ln], -2)
        frame = bound.bullet.link_frame(body, ln)
        if j == -2 or (np.abs(p[j] - np.asarray(frame[0])).max() > 1e-6
                       or np.abs(r[j] - quat_matrix(frame[1])).max() > 1e-6):
            return None
        data = pb.getCollisionShapeData(body, ln, physicsClientId=cid)
        joints.append(j)
        # everything the link's parts are made of (link_parts: the shapes with their meshes by content and
        # kind, the inertial frame; the base's in the root frame), so an entry is found without reading the
        # parts: one is only ever stored for parts that were read, and a mesh not read names no entry
        if ln >= 0:
            inertial: Any = pb.getLinkState(body, ln, physicsClientId=cid)[2:4]
        else:
            com_p, com_r = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
            inertial = (((np.asarray(com_p) - p[j]) @ r[j]).tobytes(),
                        (r[j].T @ quat_matrix(com_r)).tobytes())
        bullet = (ln, ln in moving, [shape_cache.by_content(row) for row in data], inertial)

        def fit(at: int = ln, jj: int = j) -> dict[str, Any]:
            parts = link_parts(cid, body, at)
            if parts is None:
                raise _Unreadable
            if at < 0:  # the base's points are in the world: into the root frame
                parts = [(pts - p[jj]) @ r[jj] for pts in parts]
            return fit_link(parts, link_balls(cid, body, at) if at in moving else None)

        try:
            fitted = shape_cache.cached(len(data), bullet, fit)
        except _Unreadable:
            return None
        own = np.array([row[2] not in (pb.GEOM_SPHERE, pb.GEOM_CAPSULE) for row in data], dtype=np.bool_)
        shapes.append(LinkShapes.made(ln, ln in moving, fitted, own))
    parent = {ln: int(pb.getJointInfo(body, ln, physicsClientId=cid)[16]) for ln in links if ln >= 0}
    pairs = [(i, k) for i, a in enumerate(links) for k, b in enumerate(links)
             if i < k and parent.get(a) != b and parent.get(b) != a
             and (min(a, b), max(a, b)) not in filtered]
    mass = {ln: float(pb.getDynamicsInfo(body, ln, physicsClientId=cid)[0]) for ln in links}
    # Bullet pairs a body without mass (static: a fixed base, a massless link) only with one that has mass
    hit_pairs = [(i, k) for i, k in pairs if mass[links[i]] > 0 or mass[links[k]] > 0]
    arrays = shapes_of(shapes, joints, pairs, hit_pairs)
    return RobotShapes(tree, tuple(shapes), tuple(pairs), arrays, _reach(tree, shapes, joints),
                       pair_tables(tree, arrays, *model.limits()))
