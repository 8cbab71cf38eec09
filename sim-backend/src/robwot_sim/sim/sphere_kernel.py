"""Compiled kernels of the outer bounds (``outerbounds.py``): forward kinematics of a whole joint tree and
the tests of one configuration after another, and the distance grids they look up.

Compiled by numba on first use and cached on disk (``cache=True``: next to this file, or numba's user-wide
cache where that is not writable), so a later process loads them instead of compiling. The kernels are
generic: a robot is arrays (its joint tree, its shapes, its link pairs), never code of its own.

The arrays come in named tuples (``robot_shapes.py``, ``outerbounds.py``). ``Tree``: the joints in an order
where a joint's parent comes first. ``parent[j]``: the joint whose child link is joint j's parent link, or
-1 for the root link; ``kind[j]``: 0 fixed, 1 revolute (or continuous), 2 prismatic; ``origin_p[j]`` (3,),
``origin_r[j]`` (3, 3): its origin in the parent link's frame; ``axis[j]`` (3,); its value ``coupling[j] . q
+ offset[j]`` (a controllable joint: one 1 in its row; a follower: its rule; fixed: zeros). Frame ``j`` is
joint j's child link's URDF frame; frame ``n`` (the joint count) is the root's, the base pose ``base_p``,
``base_r``.

``Shapes`` of the robot's links with collision shapes, each in its own frame ``joint[l]`` (-1: the root):
spheres ``sphere_c``/``sphere_r`` (link ``l``: ``sphere_first[l]``..``sphere_end[l]``; each covering a
part of its link, ``sphere_part``) inside a ball
``ball_c``/``ball_r``, for the other bodies; per convex part a box (``box_c``, axes as columns
``box_axes``, half extents ``box_half``, inside the ball of radius ``box_r`` about its centre) and a hull's
vertices (``verts[vert_first[p]:vert_end[p]]``), the parts of link ``l`` ``part_first[l]``..``part_end[l]``
inside the ball ``link_c``/``link_r``, for the self pairs ``pair_a[k]``, ``pair_b[k]``. Balls inside
the link's parts (``surehit.py``: ``inner_c``/``inner_r``, link ``l``: ``inner_first[l]``..
``inner_end[l]``, largest first) for sure hits, against exact bodies (``Bodies.exact``: primitives, not
the bounding boxes of meshes and other robots) and in the pairs ``hit_a[k]``, ``hit_b[k]``.

``Bodies``: the other bodies, ``kind`` 0 box (half sizes), 1 sphere (radius), 2 cylinder (radius, half
length along its z), ``centre``, ``rotation`` (world -> its frame: ``(p - centre) @ rotation``).

``Grid``: over voxels of ``side`` from corner ``lo`` (C order, ``shape``), the three least signed
distances from a voxel's centre to a body (``d[v]``, float32, +inf where none is within the grid's reach)
and the bodies of the two least (``near[v]``, -1: none); ``bodies_lo``..``bodies_hi``: the bodies'
box grown by that reach (a point outside it is farther than the reach from every body).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

if TYPE_CHECKING:
    from robwot_sim.sim.outerbounds import Bodies, Grid
    from robwot_sim.sim.robot_shapes import Shapes, Tree

#: iterations of the search for a direction separating two parts' hulls
GILBERT_STEPS = 24

Array = np.ndarray


@njit(cache=True, nogil=True, inline="always")
def _sdf(b: Bodies, k: int, x: float, y: float, z: float) -> float:
    """Signed distance (m, negative inside) of point (x, y, z) to body ``k``."""
    c, rot, size = b.centre[k], b.rotation[k], b.size[k]
    dx, dy, dz = x - c[0], y - c[1], z - c[2]
    lx = dx * rot[0, 0] + dy * rot[1, 0] + dz * rot[2, 0]
    ly = dx * rot[0, 1] + dy * rot[1, 1] + dz * rot[2, 1]
    lz = dx * rot[0, 2] + dy * rot[1, 2] + dz * rot[2, 2]
    if b.kind[k] == 1:
        return float(math.sqrt(lx * lx + ly * ly + lz * lz) - size[0])
    if b.kind[k] == 0:
        qx, qy, qz = abs(lx) - size[0], abs(ly) - size[1], abs(lz) - size[2]
    else:
        qx, qy, qz = math.sqrt(lx * lx + ly * ly) - size[0], abs(lz) - size[1], -np.inf
    inside = min(max(qx, max(qy, qz)), 0.0)
    ox, oy, oz = max(qx, 0.0), max(qy, 0.0), max(qz, 0.0)
    return float(math.sqrt(ox * ox + oy * oy + oz * oz) + inside)


@njit(cache=True, nogil=True)
def fill_grid(g: Grid, b: Bodies, low: Array, high: Array) -> None:
    """``g.d`` and ``g.near`` (filled with +inf and -1) over the voxels of each body's box ``low[k]``..
    ``high[k]`` (the body's box grown by the grid's reach)."""
    ny, nz = g.shape[1], g.shape[2]
    a = np.empty(3, np.int64)
    e = np.empty(3, np.int64)
    for k in range(b.kind.shape[0]):
        for d in range(3):
            a[d] = min(max(math.floor((low[k, d] - g.lo[d]) / g.side), 0), g.shape[d])
            e[d] = min(max(math.ceil((high[k, d] - g.lo[d]) / g.side), 0), g.shape[d])
        for i in range(a[0], e[0]):
            x = g.lo[0] + (i + 0.5) * g.side
            for j in range(a[1], e[1]):
                y = g.lo[1] + (j + 0.5) * g.side
                for m in range(a[2], e[2]):
                    s = np.float32(_sdf(b, k, x, y, g.lo[2] + (m + 0.5) * g.side))
                    v = (i * ny + j) * nz + m
                    dist = g.d[v]
                    if s >= dist[2]:
                        continue
                    if s < dist[0]:
                        dist[2], dist[1], dist[0] = dist[1], dist[0], s
                        g.near[v, 1] = g.near[v, 0]
                        g.near[v, 0] = k
                    elif s < dist[1]:
                        dist[2], dist[1] = dist[1], s
                        g.near[v, 1] = k
                    else:
                        dist[2] = s


@njit(cache=True, nogil=True)
def frames(t: Tree, q: Array, P: Array, R: Array) -> None:
    """Every joint's frame for configuration ``q`` into ``P`` (n + 1, 3) and ``R`` (n + 1, 3, 3), the root's
    included."""
    n = t.parent.shape[0]
    P[n] = t.base_p
    R[n] = t.base_r
    m = np.empty((3, 3))
    for j in range(n):
        p = t.parent[j] if t.parent[j] >= 0 else n
        o, orr = t.origin_p[j], t.origin_r[j]
        for r in range(3):
            P[j, r] = P[p, r] + R[p, r, 0] * o[0] + R[p, r, 1] * o[1] + R[p, r, 2] * o[2]
            for c in range(3):
                R[j, r, c] = R[p, r, 0] * orr[0, c] + R[p, r, 1] * orr[1, c] + R[p, r, 2] * orr[2, c]
        if t.kind[j] == 0:
            continue
        v = t.offset[j]
        for k in range(q.shape[0]):
            v += t.coupling[j, k] * q[k]
        ax, ay, az = t.axis[j, 0], t.axis[j, 1], t.axis[j, 2]
        if t.kind[j] == 2:
            for r in range(3):
                P[j, r] += (R[j, r, 0] * ax + R[j, r, 1] * ay + R[j, r, 2] * az) * v
            continue
        s, c1 = math.sin(v), 1.0 - math.cos(v)  # Rodrigues: I + s K + (1 - cos) K^2, unit axis
        m[0, 0] = 1.0 - c1 * (ay * ay + az * az)
        m[0, 1] = -s * az + c1 * ax * ay
        m[0, 2] = s * ay + c1 * ax * az
        m[1, 0] = s * az + c1 * ax * ay
        m[1, 1] = 1.0 - c1 * (ax * ax + az * az)
        m[1, 2] = -s * ax + c1 * ay * az
        m[2, 0] = -s * ay + c1 * ax * az
        m[2, 1] = s * ax + c1 * ay * az
        m[2, 2] = 1.0 - c1 * (ax * ax + ay * ay)
        for r in range(3):
            a0, a1, a2 = R[j, r, 0], R[j, r, 1], R[j, r, 2]
            for c in range(3):
                R[j, r, c] = a0 * m[0, c] + a1 * m[1, c] + a2 * m[2, c]


@njit(cache=True, nogil=True, inline="always")
def _place(P: Array, R: Array, f: int, local: Array, out: Array) -> None:
    """Point ``local`` of frame ``f`` in the world, into ``out``."""
    for r in range(3):
        out[r] = P[f, r] + R[f, r, 0] * local[0] + R[f, r, 1] * local[1] + R[f, r, 2] * local[2]


UNKNOWN = -1


@njit(cache=True, nogil=True, inline="always")
def _voxel(g: Grid, x: float, y: float, z: float) -> tuple[int, float]:
    """The voxel holding (x, y, z) and the point's distance to its centre, or (-1, 0) outside the grid."""
    gx, gy, gz = (x - g.lo[0]) / g.side, (y - g.lo[1]) / g.side, (z - g.lo[2]) / g.side
    if gx < 0.0 or gy < 0.0 or gz < 0.0 or gx >= g.shape[0] or gy >= g.shape[1] or gz >= g.shape[2]:
        return -1, 0.0
    ix, iy, iz = int(gx), int(gy), int(gz)
    ex, ey, ez = gx - ix - 0.5, gy - iy - 0.5, gz - iz - 0.5
    return (ix * g.shape[1] + iy) * g.shape[2] + iz, g.side * math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True, inline="always")
def _near(g: Grid, b: Bodies, x: float, y: float, z: float, need: float, exact: bool, tolerance: float,
          found: Array) -> int:
    """How many bodies may come within ``need`` of (x, y, z), written to ``found``: 0 outside the bodies'
    box, or where the voxel's least distance less the point's distance to the voxel's centre exceeds
    ``need`` (a distance changes no faster than the point); with ``exact``, the voxel's one or two nearest
    bodies where the next least distance bounds all others, those whose exact distance exceeds ``need``
    left out; else ``UNKNOWN`` (inside the bodies' box but outside the grid, too)."""
    if (x < g.bodies_lo[0] or y < g.bodies_lo[1] or z < g.bodies_lo[2]
            or x > g.bodies_hi[0] or y > g.bodies_hi[1] or z > g.bodies_hi[2]):
        return 0
    v, gap = _voxel(g, x, y, z)
    if v < 0:
        return UNKNOWN
    gap += tolerance
    if g.d[v, 0] - gap > need:
        return 0
    if not exact:
        return UNKNOWN
    count = 0
    for j in range(2):
        if g.d[v, j] - gap > need:
            return count
        k = g.near[v, j]
        if _sdf(b, k, x, y, z) - tolerance <= need:
            found[count] = k
            count += 1
    return count if g.d[v, 2] - gap > need else UNKNOWN


@njit(cache=True, nogil=True, inline="always")
def _body_support(b: Bodies, k: int, ux: float, uy: float, uz: float, out: Array) -> None:
    """The point of body ``k`` farthest along world direction u, into ``out``."""
    c, rot, size = b.centre[k], b.rotation[k], b.size[k]
    lx = rot[0, 0] * ux + rot[1, 0] * uy + rot[2, 0] * uz  # u in the body's frame
    ly = rot[0, 1] * ux + rot[1, 1] * uy + rot[2, 1] * uz
    lz = rot[0, 2] * ux + rot[1, 2] * uy + rot[2, 2] * uz
    if b.kind[k] == 1:
        norm = math.sqrt(lx * lx + ly * ly + lz * lz) + 1e-300
        px, py, pz = size[0] * lx / norm, size[0] * ly / norm, size[0] * lz / norm
    elif b.kind[k] == 0:
        px = size[0] if lx >= 0.0 else -size[0]
        py = size[1] if ly >= 0.0 else -size[1]
        pz = size[2] if lz >= 0.0 else -size[2]
    else:
        norm = math.sqrt(lx * lx + ly * ly)
        px, py = (size[0] * lx / norm, size[0] * ly / norm) if norm > 0.0 else (0.0, 0.0)
        pz = size[1] if lz >= 0.0 else -size[1]
    for r in range(3):
        out[r] = c[r] + rot[r, 0] * px + rot[r, 1] * py + rot[r, 2] * pz


@njit(cache=True, nogil=True, inline="always")
def _support(s: Shapes, p: int, P: Array, R: Array, f: int, ux: float, uy: float, uz: float,
             out: Array) -> None:
    """The vertex of part ``p`` (frame ``f``) farthest along world direction u, in the world, into ``out``."""
    lx = R[f, 0, 0] * ux + R[f, 1, 0] * uy + R[f, 2, 0] * uz
    ly = R[f, 0, 1] * ux + R[f, 1, 1] * uy + R[f, 2, 1] * uz
    lz = R[f, 0, 2] * ux + R[f, 1, 2] * uy + R[f, 2, 2] * uz
    best, kb = -np.inf, s.vert_first[p]
    for k in range(s.vert_first[p], s.vert_end[p]):
        d = lx * s.verts[k, 0] + ly * s.verts[k, 1] + lz * s.verts[k, 2]
        if d > best:
            best, kb = d, k
    _place(P, R, f, s.verts[kb], out)


@njit(cache=True, nogil=True)
def _apart(s: Shapes, pa: int, fa: int, pb: int, fb: int, b: Bodies, body: int, P: Array, R: Array, u: Array,
           delta: float, sa: Array, sb: Array) -> bool:
    """True when the hull of part ``pa`` (frame ``fa``) and B, the hull of part ``pb`` (frame ``fb``) or
    with ``body`` >= 0 that body, are proven more than ``delta`` apart: a direction n is found (Gilbert's
    iteration on their difference A - B, from ``u``, the direction from A towards B) with min over A of
    n.a - max over B of n.b > delta, computed from their support points themselves, so the answer is sound
    however the iteration fares (it only finds n)."""
    _support(s, pa, P, R, fa, u[0], u[1], u[2], sa)
    if body >= 0:
        _body_support(b, body, -u[0], -u[1], -u[2], sb)
    else:
        _support(s, pb, P, R, fb, -u[0], -u[1], -u[2], sb)
    vx, vy, vz = sa[0] - sb[0], sa[1] - sb[1], sa[2] - sb[2]  # a point of A - B
    for _ in range(GILBERT_STEPS):
        vv = vx * vx + vy * vy + vz * vz
        if vv < 1e-18:
            return False
        _support(s, pa, P, R, fa, -vx, -vy, -vz, sa)
        if body >= 0:
            _body_support(b, body, vx, vy, vz, sb)
        else:
            _support(s, pb, P, R, fb, vx, vy, vz, sb)
        wx, wy, wz = sa[0] - sb[0], sa[1] - sb[1], sa[2] - sb[2]  # A - B's point least along v
        vw = vx * wx + vy * wy + vz * wz
        if vw > delta * math.sqrt(vv):
            return True
        if vv - vw <= 1e-9 * vv:
            return False
        dx, dy, dz = wx - vx, wy - vy, wz - vz
        t = min(max(-(vx * dx + vy * dy + vz * dz) / (dx * dx + dy * dy + dz * dz), 0.0), 1.0)
        vx, vy, vz = vx + t * dx, vy + t * dy, vz + t * dz
    return False


@njit(cache=True, nogil=True, inline="always")
def _boxes_apart(ca: Array, ra: Array, ha: Array, cb: Array, rb: Array, hb: Array, grow: float,
                 r: Array, ar: Array) -> bool:
    """Boxes A and B (centres, axes as columns, half extents, both grown by ``grow``) apart by the
    separating-axis test (the faces' 6 normals, the edges' 9 cross products); ``r``, ``ar``: scratch."""
    t0 = (cb[0] - ca[0]) * ra[0, 0] + (cb[1] - ca[1]) * ra[1, 0] + (cb[2] - ca[2]) * ra[2, 0]
    t1 = (cb[0] - ca[0]) * ra[0, 1] + (cb[1] - ca[1]) * ra[1, 1] + (cb[2] - ca[2]) * ra[2, 1]
    t2 = (cb[0] - ca[0]) * ra[0, 2] + (cb[1] - ca[1]) * ra[1, 2] + (cb[2] - ca[2]) * ra[2, 2]
    t = (t0, t1, t2)
    a = (ha[0] + grow, ha[1] + grow, ha[2] + grow)
    b = (hb[0] + grow, hb[1] + grow, hb[2] + grow)
    for i in range(3):
        for j in range(3):
            r[i, j] = ra[0, i] * rb[0, j] + ra[1, i] * rb[1, j] + ra[2, i] * rb[2, j]
            ar[i, j] = abs(r[i, j]) + 1e-9
    for i in range(3):
        if abs(t[i]) > a[i] + ar[i, 0] * b[0] + ar[i, 1] * b[1] + ar[i, 2] * b[2]:
            return True
    for j in range(3):
        if abs(t[0] * r[0, j] + t[1] * r[1, j] + t[2] * r[2, j]) > (
                a[0] * ar[0, j] + a[1] * ar[1, j] + a[2] * ar[2, j] + b[j]):
            return True
    for i in range(3):
        i1, i2 = (i + 1) % 3, (i + 2) % 3
        for j in range(3):
            j1, j2 = (j + 1) % 3, (j + 2) % 3
            if abs(t[i2] * r[i1, j] - t[i1] * r[i2, j]) > (a[i1] * ar[i2, j] + a[i2] * ar[i1, j]
                                                           + b[j1] * ar[i, j2] + b[j2] * ar[i, j1]):
                return True
    return False


@njit(cache=True, nogil=True)
def classify(qs: Array, t: Tree, s: Shapes, b: Bodies, grid: Grid, zone: Grid, margin: float,
             body_gap: float, hull_gap: float, tolerance: float, self_always: bool, hits: bool, depth: float,
             out: Array) -> None:
    """Per row of ``qs``: bit 1 set where a sphere of a moving link may come within ``margin`` of a body
    (a link whose ball the coarse ``zone`` finds clear is not looked at further; a sphere by the fine
    ``grid``, exactly where one or two bodies only can be near, and then its part's hull kept more than
    ``body_gap`` plus the margin from them), bit 2 where two parts of a checked link pair may
    come within ``hull_gap`` (link balls, then part balls, boxes, hulls), for every row or (not
    ``self_always``) only the rows clear of the bodies (bit 2 then set untested). With ``hits``, a row
    not found free that surely collides (``_hit``, by more than ``depth``) is 4 instead."""
    n = t.parent.shape[0]
    nl = s.joint.shape[0]
    P = np.empty((n + 1, 3))
    R = np.empty((n + 1, 3, 3))
    w = np.empty(3)
    bc = np.empty((nl, 3))
    BC = np.empty((s.box_c.shape[0], 3))
    BA = np.empty((s.box_c.shape[0], 3, 3))
    placed = np.full(s.box_c.shape[0], -1, np.int64)  # the row whose centre BC holds, per part
    turned = np.full(s.box_c.shape[0], -1, np.int64)  # the row whose axes BA holds, per part
    r33, a33 = np.empty((3, 3)), np.empty((3, 3))
    u, sa, sb = np.empty(3), np.empty(3), np.empty(3)
    found = np.empty(2, np.int64)
    near_a = np.empty(s.box_c.shape[0], np.int64)
    near_b = np.empty(s.box_c.shape[0], np.int64)
    for i in range(qs.shape[0]):
        frames(t, qs[i], P, R)
        status = 0
        for ln in range(nl):
            if not s.moving[ln]:
                continue
            f = s.joint[ln] if s.joint[ln] >= 0 else n
            _place(P, R, f, s.ball_c[ln], w)
            if _near(zone, b, w[0], w[1], w[2], s.ball_r[ln] + margin, False, tolerance, found) == 0:
                continue
            for k in range(s.sphere_first[ln], s.sphere_end[ln]):
                _place(P, R, f, s.sphere_c[k], w)
                count = _near(grid, b, w[0], w[1], w[2], s.sphere_r[k] + margin, True, tolerance, found)
                p = s.sphere_part[k]
                for j in range(max(count, 0)):  # the sphere's part against each body that may be near
                    _place(P, R, f, s.box_c[p], sa)
                    for r in range(3):
                        u[r] = b.centre[found[j], r] - sa[r]
                    gap = body_gap + margin + tolerance
                    if not _apart(s, p, f, -1, -1, b, found[j], P, R, u, gap, sa, sb):
                        count = UNKNOWN
                        break
                if count == UNKNOWN:
                    status = 1
                    break
            if status:
                break
        if status and not self_always:
            out[i] = 4 if hits and _hit(s, b, grid, P, R, n, bc, depth, tolerance, w) else 3
            continue
        for ln in range(nl):
            _place(P, R, s.joint[ln] if s.joint[ln] >= 0 else n, s.link_c[ln], bc[ln])
        for k in range(s.pair_a.shape[0]):
            la, lb = s.pair_a[k], s.pair_b[k]
            dx, dy, dz = bc[la, 0] - bc[lb, 0], bc[la, 1] - bc[lb, 1], bc[la, 2] - bc[lb, 2]
            reach = s.link_r[la] + s.link_r[lb] + hull_gap + tolerance
            if dx * dx + dy * dy + dz * dz > reach * reach:
                continue
            fa = s.joint[la] if s.joint[la] >= 0 else n
            fb = s.joint[lb] if s.joint[lb] >= 0 else n
            if not _pair_apart(s, b, la, fa, lb, fb, i, P, R, bc, BC, BA, placed, turned, near_a, near_b,
                               hull_gap, tolerance, r33, a33, u, sa, sb):
                status |= 2
                break
        out[i] = 4 if status and hits and _hit(s, b, grid, P, R, n, bc, depth, tolerance, w) else status


@njit(cache=True, nogil=True)
def _hit(s: Shapes, b: Bodies, g: Grid, P: Array, R: Array, n: int, bc: Array, depth: float,
         tolerance: float, w: Array) -> bool:
    """The configuration in ``P``, ``R`` surely collides: an inner ball of a moving link reaches more
    than ``depth`` into an exact body (one of its voxel's two nearest, by its exact distance), or inner
    balls of a
    link pair Bullet checks (``hit_a``, ``hit_b``: both links with mass) overlap by more than ``depth``
    (the links' inner balls, largest first; ``self_balls`` of each compared). ``bc``: scratch."""
    nl = s.joint.shape[0]
    for ln in range(nl):
        if not s.moving[ln]:
            continue
        f = s.joint[ln] if s.joint[ln] >= 0 else n
        for k in range(s.inner_first[ln], s.inner_end[ln]):
            _place(P, R, f, s.inner_c[k], w)
            v, gap = _voxel(g, w[0], w[1], w[2])
            if v < 0 or g.d[v, 0] - gap - tolerance >= s.inner_r[k] - depth:
                continue
            for j in range(2):
                m = g.near[v, j]
                if m >= 0 and b.exact[m] and _sdf(b, m, w[0], w[1], w[2]) + tolerance < s.inner_r[k] - depth:
                    return True
    for k in range(s.hit_a.shape[0]):
        la, lb = s.hit_a[k], s.hit_b[k]
        fa = s.joint[la] if s.joint[la] >= 0 else n
        fb = s.joint[lb] if s.joint[lb] >= 0 else n
        for ka in range(s.inner_first[la], min(s.inner_end[la], s.inner_first[la] + s.self_balls)):
            _place(P, R, fa, s.inner_c[ka], w)
            for kb in range(s.inner_first[lb], min(s.inner_end[lb], s.inner_first[lb] + s.self_balls)):
                _place(P, R, fb, s.inner_c[kb], bc[0])
                dx, dy, dz = w[0] - bc[0, 0], w[1] - bc[0, 1], w[2] - bc[0, 2]
                lim = s.inner_r[ka] + s.inner_r[kb] - depth - tolerance
                if lim > 0.0 and dx * dx + dy * dy + dz * dz < lim * lim:
                    return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _turn(s: Shapes, m: int, f: int, row: int, R: Array, BA: Array, turned: Array) -> None:
    """Part ``m``'s box axes in the world (frame ``f``) into ``BA[m]``, once per row (``turned``)."""
    if turned[m] == row:
        return
    turned[m] = row
    for r in range(3):
        for col in range(3):
            BA[m, r, col] = (R[f, r, 0] * s.box_axes[m, 0, col] + R[f, r, 1] * s.box_axes[m, 1, col]
                             + R[f, r, 2] * s.box_axes[m, 2, col])


@njit(cache=True, nogil=True, inline="always")
def _near_parts(s: Shapes, ln: int, f: int, other: int, row: int, P: Array, R: Array, bc: Array, BC: Array,
                placed: Array, hull_gap: float, tolerance: float, near: Array) -> int:
    """The parts of link ``ln`` (frame ``f``) whose balls come within ``hull_gap`` of link ``other``'s
    ball, into ``near``; how many."""
    count = 0
    for m in range(s.part_first[ln], s.part_end[ln]):
        if placed[m] != row:
            placed[m] = row
            _place(P, R, f, s.box_c[m], BC[m])
        dx, dy, dz = BC[m, 0] - bc[other, 0], BC[m, 1] - bc[other, 1], BC[m, 2] - bc[other, 2]
        lim = s.box_r[m] + s.link_r[other] + hull_gap + tolerance
        if dx * dx + dy * dy + dz * dz <= lim * lim:
            near[count] = m
            count += 1
    return count


@njit(cache=True, nogil=True, inline="always")
def _pair_apart(s: Shapes, b: Bodies, la: int, fa: int, lb: int, fb: int, row: int, P: Array, R: Array,
                bc: Array, BC: Array, BA: Array, placed: Array, turned: Array, near_a: Array, near_b: Array,
                hull_gap: float, tolerance: float, r33: Array, a33: Array, u: Array, sa: Array,
                sb: Array) -> bool:
    """Every part of link ``la`` (frame ``fa``; its ball's centre in the world ``bc[la]``) more than
    ``hull_gap`` from every part of ``lb``: of the parts of each that come near the other link's ball,
    every pair's balls apart, else their boxes grown by half the gap, else their hulls (``_apart``). A
    part's box centre (``BC``) and axes (``BA``) in the world are computed once per row (``placed``,
    ``turned``); ``near_a``, ``near_b``: scratch."""
    count_a = _near_parts(s, la, fa, lb, row, P, R, bc, BC, placed, hull_gap, tolerance, near_a)
    if count_a == 0:
        return True
    count_b = _near_parts(s, lb, fb, la, row, P, R, bc, BC, placed, hull_gap, tolerance, near_b)
    for i in range(count_a):
        pa = near_a[i]
        for j in range(count_b):
            pb = near_b[j]
            dx, dy, dz = BC[pa, 0] - BC[pb, 0], BC[pa, 1] - BC[pb, 1], BC[pa, 2] - BC[pb, 2]
            lim = s.box_r[pa] + s.box_r[pb] + hull_gap + tolerance
            if dx * dx + dy * dy + dz * dz > lim * lim:
                continue
            _turn(s, pa, fa, row, R, BA, turned)
            _turn(s, pb, fb, row, R, BA, turned)
            if _boxes_apart(BC[pa], BA[pa], s.box_half[pa], BC[pb], BA[pb], s.box_half[pb],
                            hull_gap / 2 + tolerance, r33, a33):
                continue
            u[0], u[1], u[2] = -dx, -dy, -dz
            if not _apart(s, pa, fa, pb, fb, b, -1, P, R, u, hull_gap + tolerance, sa, sb):
                return False
    return True
