"""Compiled sure hits of the outer bounds (``bounds_kernel.classify`` with ``hits``): tests that a
configuration surely collides, by more than a depth, so that no Bullet call is needed to label it
colliding. The arrays and how the kernels are compiled: ``sphere_kernel.py``.

A point counts only if it is a point of the shape it stands for: a part's corners (its hull's vertices
moved onto the part itself, ``corners``) where the part is its own hull (``own``: not a sphere's or a
capsule's box), a primitive obstacle's points on its axes (``_body_inside``), inner balls inside the links'
parts. Each test asks for the point more than ``depth`` plus the tolerance inside the other shape, by an
exact signed distance (a primitive) or by the planes of a convex hull's faces (Bullet's own shape of a
part).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from robwot_sim.sim.gjk_kernel import sunk
from robwot_sim.sim.sphere_kernel import body_sdf, kernel, place, voxel_of

if TYPE_CHECKING:
    from robwot_sim.sim.outerbounds import Bodies, Grid
    from robwot_sim.sim.robot_shapes import Shapes

Array = np.ndarray


@njit(cache=True, nogil=True, inline="always")
def _inside(s: Shapes, p: int, f: int, P: Array, R: Array, wx: float, wy: float, wz: float,
            depth: float) -> bool:
    """World point (wx, wy, wz) lies more than ``depth`` inside the convex hull of part ``p`` (frame ``f``),
    by the planes of its faces (none: never)."""
    dx, dy, dz = wx - P[f, 0], wy - P[f, 1], wz - P[f, 2]
    x = R[f, 0, 0] * dx + R[f, 1, 0] * dy + R[f, 2, 0] * dz  # into frame f
    y = R[f, 0, 1] * dx + R[f, 1, 1] * dy + R[f, 2, 1] * dz
    z = R[f, 0, 2] * dx + R[f, 1, 2] * dy + R[f, 2, 2] * dz
    for h in range(s.face_first[p], s.face_end[p]):
        if s.faces[h, 0] * x + s.faces[h, 1] * y + s.faces[h, 2] * z + s.faces[h, 3] >= -depth:
            return False
    return bool(s.face_end[p] > s.face_first[p])


@njit(cache=True, nogil=True, inline="always")
def _corner_inside(s: Shapes, pa: int, fa: int, pb: int, fb: int, P: Array, R: Array, depth: float,
                   w: Array) -> bool:
    """A corner of part ``pa`` (frame ``fa``) lies more than ``depth`` inside the convex hull of part
    ``pb`` (frame ``fb``)."""
    for v in range(s.vert_first[pa], s.vert_end[pa]):
        place(P, R, fa, s.corners[v], w)
        if _inside(s, pb, fb, P, R, w[0], w[1], w[2], depth):
            return True
    return False


@njit(cache=True, nogil=True, inline="always")
def _body_inside(s: Shapes, b: Bodies, k: int, p: int, f: int, P: Array, R: Array, depth: float) -> bool:
    """A point of body ``k`` lies more than ``depth`` inside the convex hull of part ``p`` (frame ``f``): of
    the points -1, 0, 1 times its half sizes along its axes those in it (a box: all 27; a cylinder: on its
    axis and its rims' four points on its axes, at its ends and middle; a sphere: its centre and six points
    of its surface)."""
    kind, a, c = b.kind[k], b.size[k, 0], b.size[k, 1]
    for m in range(27):
        i, j, h = m % 3 - 1, (m // 3) % 3 - 1, m // 9 - 1
        if kind == 0:
            lx, ly, lz = i * a, j * c, h * b.size[k, 2]
        elif kind == 2:
            if i != 0 and j != 0:
                continue
            lx, ly, lz = i * a, j * a, h * c
        else:
            if abs(i) + abs(j) + abs(h) > 1:
                continue
            lx, ly, lz = i * a, j * a, h * a
        rot = b.rotation
        wx = b.centre[k, 0] + rot[k, 0, 0] * lx + rot[k, 0, 1] * ly + rot[k, 0, 2] * lz
        wy = b.centre[k, 1] + rot[k, 1, 0] * lx + rot[k, 1, 1] * ly + rot[k, 1, 2] * lz
        wz = b.centre[k, 2] + rot[k, 2, 0] * lx + rot[k, 2, 1] * ly + rot[k, 2, 2] * lz
        if _inside(s, p, f, P, R, wx, wy, wz, depth):
            return True
    return False


@kernel
def sunk_pair(s: Shapes, k: int, n: int, P: Array, R: Array, depth: float, tolerance: float, w: Array,
              c: Array) -> bool:
    """Self pair ``k``, one Bullet checks (``pair_hit``), surely touches: a corner of a part of one link, a
    point of it (``own``), lies more than ``depth`` inside the convex hull of a part of the other (Bullet's
    own shape of it), of two parts whose balls overlap. ``w``, ``c``: scratch."""
    if not s.pair_hit[k]:
        return False
    la, lb = s.pair_a[k], s.pair_b[k]
    fa, fb = s.joint[la] if s.joint[la] >= 0 else n, s.joint[lb] if s.joint[lb] >= 0 else n
    for pa in range(s.part_first[la], s.part_end[la]):
        if not s.own[pa]:
            continue
        place(P, R, fa, s.box_c[pa], c)
        for pb in range(s.part_first[lb], s.part_end[lb]):
            if not s.own[pb]:
                continue
            place(P, R, fb, s.box_c[pb], w)
            dx, dy, dz = w[0] - c[0], w[1] - c[1], w[2] - c[2]
            if dx * dx + dy * dy + dz * dz >= (s.box_r[pa] + s.box_r[pb]) ** 2:
                continue
            if (_corner_inside(s, pa, fa, pb, fb, P, R, depth + tolerance, w)
                    or _corner_inside(s, pb, fb, pa, fa, P, R, depth + tolerance, w)):
                return True
    return False


@kernel
def _hit(s: Shapes, b: Bodies, g: Grid, P: Array, R: Array, n: int, bc: Array, depth: float,
         tolerance: float, w: Array) -> bool:
    """The configuration in ``P``, ``R`` surely collides: an inner ball of a moving link reaches more
    than ``depth`` into an exact body (one of its voxel's two nearest, by its exact distance), or inner
    balls of a self pair Bullet reports contacts of (``pair_hit``) overlap by more than ``depth`` (the
    links' inner balls, largest first; ``self_balls`` of each compared). ``bc``: scratch."""
    nl = s.joint.shape[0]
    for ln in range(nl):
        if not s.moving[ln]:
            continue
        f = s.joint[ln] if s.joint[ln] >= 0 else n
        for k in range(s.inner_first[ln], s.inner_end[ln]):
            place(P, R, f, s.inner_c[k], w)
            v, gap = voxel_of(g, w[0], w[1], w[2])
            if v < 0 or g.d[v, 0] - gap - tolerance >= s.inner_r[k] - depth:
                continue
            for j in range(2):
                m = g.near[v, j]
                reach = s.inner_r[k] - depth
                if m >= 0 and b.exact[m] and body_sdf(b, m, w[0], w[1], w[2]) + tolerance < reach:
                    return True
    for k in range(s.pair_a.shape[0]):
        if not s.pair_hit[k]:
            continue
        la, lb = s.pair_a[k], s.pair_b[k]
        fa = s.joint[la] if s.joint[la] >= 0 else n
        fb = s.joint[lb] if s.joint[lb] >= 0 else n
        for ka in range(s.inner_first[la], min(s.inner_end[la], s.inner_first[la] + s.self_balls)):
            place(P, R, fa, s.inner_c[ka], w)
            for kb in range(s.inner_first[lb], min(s.inner_end[lb], s.inner_first[lb] + s.self_balls)):
                place(P, R, fb, s.inner_c[kb], bc[0])
                dx, dy, dz = w[0] - bc[0, 0], w[1] - bc[0, 1], w[2] - bc[0, 2]
                lim = s.inner_r[ka] + s.inner_r[kb] - depth - tolerance
                if lim > 0.0 and dx * dx + dy * dy + dz * dz < lim * lim:
                    return True
    return False


@kernel
def sure(s: Shapes, b: Bodies, g: Grid, P: Array, R: Array, n: int, bc: Array, depth: float,
          tolerance: float, w: Array, p: int, f: int, k: int, seen: Array, row: int) -> bool:
    """The configuration in ``P``, ``R`` (row ``row``) surely collides, by more than ``depth``: ``_sunk``
    for part ``p`` (frame ``f``) and body ``k``, the pair found near, first, then ``_hit``, then
    ``_sunk_near``, then that pair by the part's whole hull (``gjk_kernel.sunk``, ``exact``)."""
    return (_sunk(s, b, p, f, k, P, R, depth, tolerance, w) or _hit(s, b, g, P, R, n, bc, depth, tolerance, w)
            or _sunk_near(s, b, g, P, R, n, depth, tolerance, w, seen, row)
            or (k >= 0 and sunk(s, b, p, f, k, P, R, depth + tolerance, w, True)))


@kernel
def _sunk_near(s: Shapes, b: Bodies, g: Grid, P: Array, R: Array, n: int, depth: float, tolerance: float,
               w: Array, seen: Array, row: int) -> bool:
    """``_sunk`` for each part of a moving link with a sphere that may reach a body, against the exact ones
    of the two nearest its centre (once per part and row: ``seen``)."""
    for ln in range(s.joint.shape[0]):
        if not s.moving[ln]:
            continue
        f = s.joint[ln] if s.joint[ln] >= 0 else n
        for k in range(s.sphere_first[ln], s.sphere_end[ln]):
            p = s.sphere_part[k]
            if seen[p] == row:
                continue
            place(P, R, f, s.sphere_c[k], w)
            v, gap = voxel_of(g, w[0], w[1], w[2])
            if v < 0 or g.d[v, 0] - gap - tolerance > s.sphere_r[k]:
                continue
            seen[p] = row
            for j in range(2):
                if g.near[v, j] >= 0 and _sunk(s, b, p, f, g.near[v, j], P, R, depth, tolerance, w):
                    return True
    return False


@kernel
def _sunk(s: Shapes, b: Bodies, p: int, f: int, k: int, P: Array, R: Array, depth: float, tolerance: float,
          w: Array) -> bool:
    """Part ``p`` (frame ``f``; -1: none), a part whose points are its own (``own``), reaches more than
    ``depth`` into body ``k``, an exact one (a primitive): the hull of its corners meets the body shrunk by
    that much (``gjk_kernel.sunk``), or a point of the body lies more than ``depth`` inside the part's
    convex hull. ``w``: scratch."""
    if p < 0 or not b.exact[k] or not s.own[p]:
        return False
    return (sunk(s, b, p, f, k, P, R, depth + tolerance, w, False)
            or _body_inside(s, b, k, p, f, P, R, depth + tolerance))
