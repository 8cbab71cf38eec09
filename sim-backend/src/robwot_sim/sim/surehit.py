"""Sure hits: configurations whose collision is certain from geometry alone, found in numpy for a whole
batch, so that Bullet checks only the others (``World.collision_free_batch``).

Why: a colliding configuration costs Bullet 5-30 times a free one (the penetration depth of every
penetrating pair of convex parts, EPA), so colliding samples took ~45 % of the labelling time of kuka with
4 obstacles and ~85 % for UR5's decomposed meshes.

How: each convex part of a moving link (a decomposed mesh part, a primitive, a hull Bullet built) gets
up to ``PER_PART`` balls that lie inside it (centres on the part's long axis, radius the distance to its
nearest face), in the URDF link frame, and every link's frame comes from the vectorised FK
(``workspace/fk.py``). A configuration is a sure hit when, by more than ``DEPTH`` (m),

- a ball reaches into a primitive obstacle (box, sphere, cylinder; signed distance < radius): every
  ball of the batch is looked up in a grid of the nearest obstacle per voxel (``_Grid``), so the test
  costs the same with 4 obstacles or 239, or
- two balls of a link pair that Bullet checks overlap (a link of it with mass, neither the other's
  parent, not a filtered pair).

Then the part and the obstacle (or the two parts) share a ball of radius > ``DEPTH``: Bullet reports a
contact of negative distance there, so the label is the one Bullet gives. Everything else (grazing
contacts, meshes, other robots) is left to Bullet, whose label of a row does not depend on the rows it
checked before (``client.Recheck``), so skipping rows changes no other row's label
(``python -m robwot_bench.surehits`` counts both).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robwot_sim.model.fk import ChainFK, chain_frames
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.types import FloatArray

PER_PART = 5  # balls per convex part, evenly along its long axis
MAX_BALLS = 16  # largest balls kept per link
SELF_BALLS = 8  # of them, the largest tested for self pairs (every pair of two links' balls is compared)
MIN_RADIUS = 0.005  # m: smaller balls are dropped
DEPTH = 0.001  # m: overlap a sure hit needs
GRID_VOXELS = 1 << 20  # most voxels of the obstacle grid (4 + 4 bytes each)
GRID_SIDE = 0.01  # m: the grid's finest voxel side
GRID_TOLERANCE = 1e-6  # m: above the float32 rounding of the grid's distances
ZONE_SIDE = 0.05  # m: voxel side of the coarse field that tells which links are near an obstacle at all
PROBE = 500  # rows of a batch tested first: below MIN_RATE sure hits among them, the rest is not tested
MIN_RATE = 0.02  # (a hit saves Bullet a colliding row, many times the test's cost per row)


@dataclass(frozen=True)
class LinkBalls:
    """Balls inside one moving link's collision parts, in its URDF link frame."""

    link: int  # Bullet link index
    centres: FloatArray  # (k, 3)
    radii: FloatArray  # (k,)


def _obj_vertices(path: Path) -> FloatArray | None:
    """Vertices of a one-object OBJ file (``v x y z`` lines); None for other files (Bullet makes one hull
    per object of a file, and the hull of all of them would be larger)."""
    if path.suffix.lower() != ".obj" or not path.is_file():
        return None
    lines = path.read_text(errors="replace").splitlines()
    if sum(line.startswith(("o ", "g ")) for line in lines) > 1:
        return None
    rows = [line.split()[1:4] for line in lines if line.startswith("v ")]
    return np.array(rows, dtype=np.float64) if rows else None


def _bullet_vertices(cid: int, body: int, link: int, shape: int) -> FloatArray:
    """Vertices of a link's convex shape number ``shape`` as Bullet holds them (``getMeshData``: the shape's
    frame applied, in the link's inertial frame); empty when Bullet gives none."""
    try:
        data = pb.getMeshData(body, link, collisionShapeIndex=shape, physicsClientId=cid)
    except pb.error:
        return np.zeros((0, 3))
    return np.asarray(data[1], dtype=np.float64).reshape(-1, 3)


def _hull_balls(vertices: FloatArray) -> list[tuple[FloatArray, float]]:
    """Up to ``PER_PART`` balls inside the convex hull of ``vertices``: centres evenly spaced inside the
    extent along the principal axis through the vertex centroid, radius the distance to the nearest hull
    face."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(vertices)
    except (QhullError, ValueError):
        return []
    eq = hull.equations  # n . x + d <= 0 inside, |n| = 1
    centre = vertices[hull.vertices].mean(axis=0)
    _, _, vt = np.linalg.svd(vertices - centre, full_matrices=False)
    axis = vt[0]
    along = (vertices - centre) @ axis
    out = []
    for t in np.linspace(along.min(), along.max(), PER_PART + 2)[1:-1]:
        c = centre + t * axis
        r = float(-(eq[:, :3] @ c + eq[:, 3]).max())
        if r >= MIN_RADIUS:
            out.append((c, r))
    return out


def _primitive_balls(kind: int, dims: Any) -> list[tuple[FloatArray, float]]:
    """Balls inside a box / sphere / cylinder / capsule centred at its frame (axis z)."""
    if kind == pb.GEOM_SPHERE:
        return [(np.zeros(3), float(dims[0]))]
    if kind == pb.GEOM_BOX:
        halves = np.asarray(dims[:3], dtype=np.float64) / 2
        rb = float(halves.min())
        ax = int(np.argmax(halves))
        out = [(np.zeros(3), rb)]
        for sign in (-1.0, 1.0):
            c = np.zeros(3)
            c[ax] = sign * max(0.0, float(halves[ax]) - rb)
            out.append((c, rb))
        return out
    if kind in (pb.GEOM_CYLINDER, pb.GEOM_CAPSULE):
        length, radius = float(dims[0]), float(dims[1])
        half = length / 2 + (radius if kind == pb.GEOM_CAPSULE else 0.0)
        r = min(radius, half)
        return [(np.array([0.0, 0.0, s * max(0.0, half - r)]), r) for s in (0.0, -1.0, 1.0)]
    return []


def link_balls(cid: int, body: int, link: int) -> LinkBalls:
    """The balls of one link of a loaded body (its collision shapes as Bullet holds them)."""
    state = pb.getLinkState(body, link, physicsClientId=cid)
    com_p, com_r = np.asarray(state[2], dtype=np.float64), quat_matrix(state[3])  # inertial frame in link
    balls: list[tuple[FloatArray, float]] = []
    for i, shape in enumerate(pb.getCollisionShapeData(body, link, physicsClientId=cid) or ()):
        kind, dims, name, pos, orn = shape[2], shape[3], shape[4], shape[5], shape[6]
        if kind == pb.GEOM_MESH:
            file = Path(name.decode(errors="replace") if isinstance(name, bytes) else str(name))
            v = _obj_vertices(file)
            if v is None and (file.name == "unknown_file" or file.suffix.lower() == ".stl"):
                # one hull Bullet built itself (a URDF cylinder or capsule without implicit shapes, an STL
                # mesh): its vertices as Bullet holds them, already in the inertial frame
                held = _bullet_vertices(cid, body, link, i)
                balls += [(com_p + com_r @ c, r) for c, r in _hull_balls(held)]
                continue
            local = [] if v is None else _hull_balls(v * np.asarray(dims, dtype=np.float64))
        else:
            local = _primitive_balls(kind, dims)
        rot, off = quat_matrix(orn), np.asarray(pos, dtype=np.float64)
        # shape frame -> inertial frame -> link frame
        balls += [(com_p + com_r @ (off + rot @ c), r) for c, r in local]
    balls.sort(key=lambda b: -b[1])
    balls = balls[:MAX_BALLS]
    return LinkBalls(link, np.array([c for c, _ in balls]).reshape(-1, 3),
                     np.array([r for _, r in balls], dtype=np.float64))


_KINDS = {"box": 0, "sphere": 1, "cylinder": 2}


class _Obstacles:
    """The primitive obstacles as arrays, for signed distances of many (point, obstacle) pairs at once:
    each obstacle's position, rotation (world -> its frame: ``(p - position) @ rotation``), kind, size
    (box: half sizes; sphere: radius; cylinder: radius and half length) and bounding-ball radius about
    its position."""

    def __init__(self, specs: list[dict[str, Any]]) -> None:
        self.count = len(specs)
        self.centre = np.array([o["position"] for o in specs], dtype=np.float64).reshape(-1, 3)
        self.rotation = np.array([quat_matrix(o["orientation"]) for o in specs]).reshape(-1, 3, 3)
        self.kind = np.array([_KINDS[o["shape"]["type"]] for o in specs], dtype=np.intp)
        size = np.zeros((self.count, 3))
        for i, o in enumerate(specs):
            s = o["shape"]
            if s["type"] == "box":
                size[i] = np.asarray(s["size"], dtype=np.float64) / 2
            elif s["type"] == "sphere":
                size[i, 0] = float(s["radius"])
            else:
                size[i, :2] = float(s["radius"]), float(s["length"]) / 2
        self.size = size
        self.reach = np.linalg.norm(size, axis=1)  # box: half diagonal; cylinder: hypot(radius, half length)
        # half sides of each obstacle's axis-aligned bounding box (world axes)
        turn = np.abs(self.rotation)
        box = np.einsum("mij,mj->mi", turn, size)
        axis = turn[:, :, 2]  # a cylinder's axis in the world
        cyl = axis * size[:, 1:2] + size[:, 0:1] * np.sqrt(np.maximum(0.0, 1.0 - axis * axis))
        self.half = np.where((self.kind == _KINDS["box"])[:, None], box,
                             np.where((self.kind == _KINDS["sphere"])[:, None], size[:, :1], cyl))

    def sdf(self, kind: int, points: FloatArray, which: npt.NDArray[np.intp]) -> FloatArray:
        """Signed distance (m, negative inside) of ``points`` ``(p, 3)`` or ``(p, k, 3)`` to obstacle
        ``which[i]`` (``(p,)``, all of ``kind``), per point."""
        extra = (None,) * (points.ndim - 2)
        offset = points - self.centre[which][(slice(None), *extra, slice(None))]
        local = np.einsum("p...i,pij->p...j", offset, self.rotation[which])
        size = self.size[which][(slice(None), *extra, slice(None))]
        if kind == _KINDS["sphere"]:
            out: FloatArray = np.linalg.norm(local, axis=-1) - size[..., 0]
            return out
        if kind == _KINDS["box"]:
            q = np.abs(local) - size
        else:
            q = np.stack([np.linalg.norm(local[..., :2], axis=-1) - size[..., 0],
                          np.abs(local[..., 2]) - size[..., 1]], axis=-1)
        return np.asarray(np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0))


def _cells(lo: FloatArray, side: float, shape: npt.NDArray[np.intp], low: FloatArray,
           high: FloatArray) -> tuple[tuple[slice, ...], list[FloatArray]]:
    """The voxels of a grid (corner ``lo``, voxel ``side``, ``shape``) that meet the box ``low``..``high``:
    their index ranges as slices and their centres' coordinates along each axis."""
    a = np.clip(np.floor((low - lo) / side), 0, shape).astype(np.intp)
    b = np.clip(np.ceil((high - lo) / side), 0, shape).astype(np.intp)
    return (tuple(slice(int(a[d]), int(b[d])) for d in range(3)),
            [lo[d] + (np.arange(a[d], b[d]) + 0.5) * side for d in range(3)])


def _strides(shape: npt.NDArray[np.intp]) -> npt.NDArray[np.intp]:
    """Flat index of a C-ordered 3-D grid's cell = its three indices . these."""
    return np.array([shape[1] * shape[2], shape[2], 1], dtype=np.intp)


class _Grid:
    """The primitive obstacles' nearest one per voxel: over the box where a ball of radius ``reach`` can
    touch one, each voxel holds the obstacle of least signed distance at its centre and that distance
    (float32; +inf where none is within ``reach`` plus a voxel). The voxel side is ``GRID_SIDE`` or
    larger, so that the grid has at most ``GRID_VOXELS`` voxels.

    A ball (centre c, radius r) in voxel v is a hit when its nearest obstacle o (that of v) has
    ``sd_o(c) < r - DEPTH``. As ``sd_o`` changes no faster than the distance,
    ``sd_o(c) >= dist(v) - |c - v|``: only the balls with ``dist(v) - |c - v| < r - DEPTH`` get the exact
    signed distance. A ball inside an obstacle other than its voxel's nearest one is not found (it then
    lies within a voxel of both): every hit is certain, not every certain hit is found."""

    def __init__(self, obs: _Obstacles, reach: float) -> None:
        self.obs = obs
        lo_o, hi_o = obs.centre - obs.half - reach, obs.centre + obs.half + reach
        self.lo = lo_o.min(axis=0)
        extent = hi_o.max(axis=0) - self.lo
        self.side = max(GRID_SIDE, float(np.prod(extent) / GRID_VOXELS) ** (1 / 3))
        self.shape = np.maximum(1, np.ceil(extent / self.side)).astype(np.intp)
        self.dist = np.full(tuple(self.shape), np.inf, dtype=np.float32)
        self.near = np.full(tuple(self.shape), -1, dtype=np.int32)
        for i in range(obs.count):
            box, axes = _cells(self.lo, self.side, self.shape, lo_o[i] - self.side, hi_o[i] + self.side)
            pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
            sd = obs.sdf(int(obs.kind[i]), pts, np.full(len(pts), i, dtype=np.intp))
            held, sd = self.dist[box], sd.reshape(tuple(len(x) for x in axes))
            better = sd < held
            held[better] = sd[better]
            self.near[box][better] = i
        self.dist[self.dist > reach + self.side] = np.inf
        self.dist_flat, self.near_flat = self.dist.ravel(), self.near.ravel()
        self.strides = _strides(self.shape).astype(np.float64)

    def hits(self, centres: FloatArray, radii: FloatArray) -> npt.NDArray[np.bool_]:
        """True per ball (``centres`` ``(n, 3, k)``: coordinates along axis 1; ``radii`` ``(k,)``) found
        reaching more than ``DEPTH`` into a primitive obstacle, ``(n, k)``. A centre outside the grid is
        taken to the nearest voxel: the bound holds there too, with the larger distance to that voxel's
        centre."""
        n, _, k = centres.shape
        at = centres * (1 / self.side) - (self.lo / self.side + 0.5)[:, None]  # voxel coordinates
        cell = np.clip(at, 0, (self.shape - 1)[:, None])
        np.rint(cell, out=cell)
        flat = np.einsum("nik,i->nk", cell, self.strides).astype(np.intp)
        # where the test can succeed at all (|c - v| <= side within a voxel)
        row, ball = np.nonzero(np.take(self.dist_flat, flat) < radii - DEPTH + self.side)
        gap = at[row, :, ball] - cell[row, :, ball]
        cells = flat[row, ball]
        r = radii[ball]
        bound = self.dist_flat[cells] - self.side * np.sqrt(np.einsum("mi,mi->m", gap, gap))
        keep = bound - GRID_TOLERANCE < r - DEPTH
        row, ball, cells, r = row[keep], ball[keep], cells[keep], r[keep]
        out = np.zeros((n, k), dtype=bool)
        which = self.near_flat[cells].astype(np.intp)
        kinds = self.obs.kind[which]
        for kind in np.unique(kinds):
            sel = kinds == kind
            inside = self.obs.sdf(int(kind), centres[row[sel], :, ball[sel]], which[sel]) < r[sel] - DEPTH
            out[row[sel][inside], ball[sel][inside]] = True
        return out


class _Zone:
    """Which links can reach an obstacle at all: a coarse field (``ZONE_SIDE``) of the distance from each
    voxel centre to the nearest primitive obstacle's axis-aligned bounding box (never more than the
    distance to the obstacle), over those boxes grown by ``far`` and a voxel (+inf beyond ``far`` plus a
    voxel). A link whose bounding ball (centre c, radius R <= ``far``) lies in a voxel v with
    ``field(v) > R + |c - v|``, or outside the field, is farther than R from every obstacle: none of its
    balls can reach one."""

    def __init__(self, obs: _Obstacles, far: float) -> None:
        grow = far + ZONE_SIDE
        self.lo = (obs.centre - obs.half).min(axis=0) - grow
        extent = (obs.centre + obs.half).max(axis=0) + grow - self.lo
        self.shape = np.maximum(1, np.ceil(extent / ZONE_SIDE)).astype(np.intp)
        self.field = np.full(tuple(self.shape), np.inf, dtype=np.float32)
        for c, h in zip(obs.centre, obs.half, strict=True):
            box, mid = _cells(self.lo, ZONE_SIDE, self.shape, c - h - grow, c + h + grow)
            x, y, z = (np.maximum(np.abs(mid[i] - c[i]) - h[i], 0.0) for i in range(3))
            d = np.sqrt(x[:, None, None] ** 2 + y[None, :, None] ** 2 + z[None, None, :] ** 2)
            np.minimum(self.field[box], d, out=self.field[box], casting="unsafe")
        self.field[self.field > grow] = np.inf
        self.field_flat = self.field.ravel()
        self.strides = _strides(self.shape)

    def near(self, centres: FloatArray, radius: float) -> npt.NDArray[np.intp]:
        """The rows of ``centres`` ``(n, 3)`` whose ball of ``radius`` may reach an obstacle."""
        at = (centres - self.lo) / ZONE_SIDE - 0.5
        cell = np.rint(at).astype(np.intp)
        rows = np.flatnonzero(((cell >= 0) & (cell < self.shape)).all(axis=1))
        gap = at[rows] - cell[rows]
        reach = radius + ZONE_SIDE * np.sqrt(np.einsum("mi,mi->m", gap, gap)) + GRID_TOLERANCE
        return np.asarray(rows[self.field_flat[cell[rows] @ self.strides] <= reach])


class SureHits:
    """Sure-hit test of one robot (see the module docstring). ``fks[i]`` gives link ``links[i].link``'s
    frame from a joint vector (``ChainFK``); ``pairs`` are the self pairs (indices into ``links``);
    ``obstacles`` the world's obstacle specs (its primitive ones are tested, through ``_Grid``). For a self
    pair, each link's balls are first tested as one bounding ball, so the ball-by-ball test runs only for
    the rows where that one reaches."""

    def __init__(self, links: list[LinkBalls], fks: list[Any], pairs: list[tuple[int, int]],
                 obstacles: list[dict[str, Any]]) -> None:
        keep = [i for i, lb in enumerate(links) if len(lb.radii)]
        index = {old: new for new, old in enumerate(keep)}
        self.links = [links[i] for i in keep]
        self.fks = [fks[i] for i in keep]
        self.pairs = [(index[a], index[b]) for a, b in pairs if a in index and b in index]
        prims = _Obstacles([o for o in obstacles if o["shape"]["type"] in _KINDS])
        self.radii = np.concatenate([lb.radii for lb in self.links]) if self.links else np.zeros(0)
        self.bound_centre = [lb.centres.mean(axis=0) for lb in self.links]
        self.bound_radius = [float((np.linalg.norm(lb.centres - c, axis=1) + lb.radii).max())
                             for lb, c in zip(self.links, self.bound_centre, strict=True)]
        near = prims.count and self.links
        self.grid = _Grid(prims, float(self.radii.max())) if near else None
        self.zone = _Zone(prims, max(self.bound_radius)) if near else None

    def hits(self, qs: FloatArray) -> npt.NDArray[np.bool_]:
        """True where the configuration (row of ``qs``) surely collides. When fewer than ``MIN_RATE`` of
        the first ``PROBE`` rows are (a robot and scene where the test does not pay), the other rows are
        left to Bullet."""
        if len(qs) <= PROBE:
            return self._hits(qs)
        probe = self._hits(qs[:PROBE])
        if probe.mean() < MIN_RATE:
            return np.concatenate([probe, np.zeros(len(qs) - PROBE, dtype=bool)])
        return np.concatenate([probe, self._hits(qs[PROBE:])])

    def _hits(self, qs: FloatArray) -> npt.NDArray[np.bool_]:
        n = len(qs)
        out = np.zeros(n, dtype=bool)
        if not self.links or n == 0:
            return out
        frames = chain_frames(self.fks, qs)

        def balls(k: int, rows: npt.NDArray[np.intp], count: int | None = None) -> FloatArray:
            """Link k's balls at ``rows``, coordinates along axis 1: ``(rows, 3, balls)``."""
            p, r = frames[k]
            return np.asarray(p[rows, :, None] + np.matmul(r[rows], self.links[k].centres[:count].T))

        centres = [p + r @ c for (p, r), c in zip(frames, self.bound_centre, strict=True)]  # (n, 3)
        if self.grid is not None and self.zone is not None:
            for k, lb in enumerate(self.links):
                rows = self.zone.near(centres[k], self.bound_radius[k])
                rows = rows[~out[rows]]
                if len(rows):
                    out[rows[self.grid.hits(balls(k, rows), lb.radii).any(axis=1)]] = True
        for a, b in self.pairs:
            d = centres[a] - centres[b]
            reach = self.bound_radius[a] + self.bound_radius[b] - DEPTH
            rows = np.flatnonzero((np.einsum("ni,ni->n", d, d) < reach * reach) & ~out)
            if not len(rows):
                continue
            # a's balls against b's bounding ball
            ba = balls(a, rows, SELF_BALLS)
            e = ba - centres[b][rows, :, None]
            lim_b = self.links[a].radii[:SELF_BALLS] + self.bound_radius[b] - DEPTH
            near = (np.einsum("nik,nik->nk", e, e) < lim_b * lim_b).any(axis=1)
            rows, ba = rows[near], ba[near]
            if len(rows):
                diff = ba[:, :, :, None] - balls(b, rows, SELF_BALLS)[:, :, None, :]
                lim = (self.links[a].radii[:SELF_BALLS, None] + self.links[b].radii[None, :SELF_BALLS]
                       - DEPTH)
                hit = (np.einsum("niab,niab->nab", diff, diff) < np.where(lim > 0, lim * lim, -1.0))
                out[rows[hit.any(axis=(1, 2))]] = True
        return out


def build_sure_hits(bound: Any, filtered: set[tuple[int, int]], model: Any,
                    obstacles: list[dict[str, Any]]) -> SureHits:
    """The sure-hit test of a loaded robot (``BoundRobot``, its filtered pairs and ``RobotModel``).
    Empty (never a hit) when the FK does not reproduce Bullet's link frames to 1e-6 m / 1e-6."""
    cid, body = bound.bullet.cid, bound.body
    links = [ln for ln in bound.moving_links if pb.getCollisionShapeData(body, ln, physicsClientId=cid)]
    fks = [ChainFK.from_joints(model.joints, model.links, bound.link_names[ln], model.controllable,
                               model.couplings, base_position=model.base_position,
                               base_orientation=model.base_orientation)
           for ln in links]
    q = np.asarray(bound.q, dtype=np.float64)[None, :]
    for ln, fk in zip(links, fks, strict=True):
        p, r = fk.poses(q)
        state = pb.getLinkState(body, ln, computeForwardKinematics=True, physicsClientId=cid)
        if (np.abs(p[0] - np.asarray(state[4])).max() > 1e-6
                or np.abs(r[0] - quat_matrix(state[5])).max() > 1e-6):
            return SureHits([], [], [], [])
    mass = {ln: float(pb.getDynamicsInfo(body, ln, physicsClientId=cid)[0]) for ln in links}
    parent = {ln: int(pb.getJointInfo(body, ln, physicsClientId=cid)[16]) for ln in links}
    pairs = [(i, j) for i, a in enumerate(links) for j, b in enumerate(links)
             if i < j and mass[a] > 0 and mass[b] > 0 and parent[a] != b and parent[b] != a
             and (min(a, b), max(a, b)) not in filtered]
    return SureHits([link_balls(cid, body, ln) for ln in links], fks, pairs, obstacles)
