"""The distance between two convex shapes of the outer bounds (``outerbounds.py``), compiled: Gilbert,
Johnson and Keerthi's algorithm (GJK) on their Minkowski difference A - B, the simplex of up to four of its
points reduced to the face, edge or vertex nearest the origin at each step (the closest-point tests of
Ericson's *Real-Time Collision Detection*, 5.1), so that on two polytopes it ends in a few steps with the
exact distance. A is a part of a link (the convex hull of points of it in its frame); B another part, or
a primitive body (box, sphere, cylinder; ``sphere_kernel.py`` says what the arrays hold), possibly shrunk.

Coal (Pinocchio's collision library) and Bullet have their GJKs, but neither can be called from a compiled
kernel, which tests millions of pairs without leaving compiled code; this one is the loop over support
points the kernels need and nothing else.

Soundness does not rest on the iteration: a lower bound of the distance is only ever taken as ``n . w``
for a unit direction n and a support point w of A - B least along n (every point of A - B is then at
least that far along n), and A and B are only said to intersect when four points of A - B, each a point
of A less a point of B, hold the origin strictly inside their tetrahedron (by the signs of four
determinants: a float error can only matter for an origin within rounding of a face, where the shapes
are within rounding of touching).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from robwot_sim.sim.sphere_kernel import kernel

if TYPE_CHECKING:
    from robwot_sim.sim.outerbounds import Bodies
    from robwot_sim.sim.robot_shapes import Shapes

#: GJK steps at most (two polytopes end in fewer; a curved body can take more, then nothing is proven)
STEPS = 32
#: relative gap between the upper and lower bound at which GJK has converged
CONVERGED = 1e-10

Array = np.ndarray
Vec = tuple[float, float, float]


@njit(cache=True, nogil=True, inline="always")
def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, nogil=True, inline="always")
def _axpy(t: float, x: Vec, y: Vec) -> Vec:
    """y + t x."""
    return (y[0] + t * x[0], y[1] + t * x[1], y[2] + t * x[2])


@njit(cache=True, nogil=True, inline="always")
def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, nogil=True, inline="always")
def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, nogil=True, inline="always")
def _segment(a: Vec, b: Vec) -> tuple[Vec, int]:
    """The point of segment ab nearest the origin and the vertices it needs (bit 1: a, 2: b)."""
    ab = _sub(b, a)
    t, d = -_dot(a, ab), _dot(ab, ab)
    if t <= 0.0:
        return a, 1
    if t >= d:
        return b, 2
    return _axpy(t / d, ab, a), 3


@njit(cache=True, nogil=True, inline="always")
def _triangle(a: Vec, b: Vec, c: Vec) -> tuple[Vec, int]:
    """The point of triangle abc nearest the origin and the vertices it needs (bits 1, 2, 4)."""
    ab, ac = _sub(b, a), _sub(c, a)
    d1, d2 = -_dot(ab, a), -_dot(ac, a)
    if d1 <= 0.0 and d2 <= 0.0:
        return a, 1
    d3, d4 = -_dot(ab, b), -_dot(ac, b)
    if d3 >= 0.0 and d4 <= d3:
        return b, 2
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        return _axpy(d1 / (d1 - d3) if d1 > d3 else 0.0, ab, a), 3
    d5, d6 = -_dot(ab, c), -_dot(ac, c)
    if d6 >= 0.0 and d5 <= d6:
        return c, 4
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        return _axpy(d2 / (d2 - d6) if d2 > d6 else 0.0, ac, a), 5
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and d4 - d3 >= 0.0 and d5 - d6 >= 0.0:
        den = (d4 - d3) + (d5 - d6)
        return _axpy((d4 - d3) / den if den > 0.0 else 0.0, _sub(c, b), b), 6
    denom = va + vb + vc
    if not denom > 0.0:  # degenerate (flat to rounding): the nearest of its edges
        p, m = _segment(a, b)
        q, mq = _segment(a, c)
        if _dot(q, q) < _dot(p, p):
            p, m = q, (mq & 1) | ((mq & 2) << 1)
        q, mq = _segment(b, c)
        if _dot(q, q) < _dot(p, p):
            p, m = q, mq << 1
        return p, m
    return _axpy(vc / denom, ac, _axpy(vb / denom, ab, a)), 7


@njit(cache=True, nogil=True, inline="always")
def _beyond(a: Vec, b: Vec, c: Vec, d: Vec) -> bool:
    """The origin is not strictly on d's side of the plane through a, b, c (a flat tetrahedron: always)."""
    n = _cross(_sub(b, a), _sub(c, a))
    return -_dot(a, n) * _dot(_sub(d, a), n) <= 0.0


@njit(cache=True, nogil=True, inline="always")
def _face(best: Vec, mask: int, a: Vec, b: Vec, c: Vec, bits: tuple[int, int, int]) -> tuple[Vec, int]:
    """The nearer to the origin of ``best`` and triangle abc's nearest point (its vertex bits renamed to
    ``bits``)."""
    p, m = _triangle(a, b, c)
    if mask != 15 and _dot(p, p) >= _dot(best, best):
        return best, mask
    out = 0
    for i in range(3):
        if m & (1 << i):
            out |= bits[i]
    return p, out


@njit(cache=True, nogil=True, inline="always")
def _tetrahedron(a: Vec, b: Vec, c: Vec, d: Vec) -> tuple[Vec, int]:
    """The point of tetrahedron abcd nearest the origin and the vertices it needs (bits 1, 2, 4, 8; 15: the
    origin is strictly inside it)."""
    p, mask = (0.0, 0.0, 0.0), 15
    if _beyond(a, b, c, d):
        p, mask = _face(p, mask, a, b, c, (1, 2, 4))
    if _beyond(a, c, d, b):
        p, mask = _face(p, mask, a, c, d, (1, 4, 8))
    if _beyond(a, d, b, c):
        p, mask = _face(p, mask, a, d, b, (1, 8, 2))
    if _beyond(b, d, c, a):
        p, mask = _face(p, mask, b, d, c, (2, 8, 4))
    return p, mask


@njit(cache=True, nogil=True, inline="always")
def part_support(pts: Array, first: int, end: int, P: Array, R: Array, f: int, ux: float, uy: float,
                 uz: float) -> Vec:
    """The point of ``pts[first:end]`` (in frame ``f``) farthest along world direction u, in the world."""
    lx = R[f, 0, 0] * ux + R[f, 1, 0] * uy + R[f, 2, 0] * uz
    ly = R[f, 0, 1] * ux + R[f, 1, 1] * uy + R[f, 2, 1] * uz
    lz = R[f, 0, 2] * ux + R[f, 1, 2] * uy + R[f, 2, 2] * uz
    best, kb = -np.inf, first
    for k in range(first, end):
        d = lx * pts[k, 0] + ly * pts[k, 1] + lz * pts[k, 2]
        if d > best:
            best, kb = d, k
    x, y, z = pts[kb, 0], pts[kb, 1], pts[kb, 2]
    return (P[f, 0] + R[f, 0, 0] * x + R[f, 0, 1] * y + R[f, 0, 2] * z,
            P[f, 1] + R[f, 1, 0] * x + R[f, 1, 1] * y + R[f, 1, 2] * z,
            P[f, 2] + R[f, 2, 0] * x + R[f, 2, 1] * y + R[f, 2, 2] * z)


@njit(cache=True, nogil=True, inline="always")
def body_support(b: Bodies, k: int, shrink: float, ux: float, uy: float, uz: float) -> Vec:
    """The point of body ``k`` shrunk by ``shrink`` (the points at least that deep inside it: a box's half
    sizes, a sphere's radius, a cylinder's radius and half length less it) farthest along world direction
    u."""
    c, rot, size = b.centre[k], b.rotation[k], b.size[k]
    lx = rot[0, 0] * ux + rot[1, 0] * uy + rot[2, 0] * uz  # u in the body's frame
    ly = rot[0, 1] * ux + rot[1, 1] * uy + rot[2, 1] * uz
    lz = rot[0, 2] * ux + rot[1, 2] * uy + rot[2, 2] * uz
    if b.kind[k] == 1:
        r = size[0] - shrink
        norm = math.sqrt(lx * lx + ly * ly + lz * lz) + 1e-300
        px, py, pz = r * lx / norm, r * ly / norm, r * lz / norm
    elif b.kind[k] == 0:
        px = size[0] - shrink if lx >= 0.0 else shrink - size[0]
        py = size[1] - shrink if ly >= 0.0 else shrink - size[1]
        pz = size[2] - shrink if lz >= 0.0 else shrink - size[2]
    else:
        r, norm = size[0] - shrink, math.sqrt(lx * lx + ly * ly)
        px, py = (r * lx / norm, r * ly / norm) if norm > 0.0 else (0.0, 0.0)
        pz = size[1] - shrink if lz >= 0.0 else shrink - size[1]
    return (c[0] + rot[0, 0] * px + rot[0, 1] * py + rot[0, 2] * pz,
            c[1] + rot[1, 0] * px + rot[1, 1] * py + rot[1, 2] * pz,
            c[2] + rot[2, 0] * px + rot[2, 1] * py + rot[2, 2] * pz)


@njit(cache=True, nogil=True, inline="always")
def _difference(pts_a: Array, a0: int, a1: int, fa: int, pts_b: Array, b0: int, b1: int, fb: int,
                b: Bodies, body: int, shrink: float, P: Array, R: Array, vx: float, vy: float,
                vz: float) -> Vec:
    """The point of A - B least along direction v: A's support along -v less B's along v."""
    a = part_support(pts_a, a0, a1, P, R, fa, -vx, -vy, -vz)
    if body >= 0:
        return _sub(a, body_support(b, body, shrink, vx, vy, vz))
    return _sub(a, part_support(pts_b, b0, b1, P, R, fb, vx, vy, vz))


@kernel
def gjk(pts_a: Array, a0: int, a1: int, fa: int, pts_b: Array, b0: int, b1: int, fb: int, b: Bodies,
        body: int, shrink: float, P: Array, R: Array, u: Array, enough: float,
        least: float) -> tuple[float, bool]:
    """A lower bound of the distance between A, the hull of ``pts_a[a0:a1]`` in frame ``fa``, and B, the
    hull of ``pts_b[b0:b1]`` in frame ``fb`` or with ``body`` >= 0 that body shrunk by ``shrink`` (-inf: none
    found), and whether they surely intersect; ``u``: a direction from A towards B to start from. Returned
    once the bound exceeds ``enough``, once the upper bound (the length of GJK's iterate) is no more than
    ``least`` (the bound can then not exceed it), once they converge, or after ``STEPS``."""
    w0 = _difference(pts_a, a0, a1, fa, pts_b, b0, b1, fb, b, body, shrink, P, R, -u[0], -u[1], -u[2])
    w1, w2, w3 = w0, w0, w0
    count, v = 1, w0
    best = -math.inf
    for _ in range(STEPS):
        vv = _dot(v, v)
        if vv < 1e-24 or vv <= least * abs(least):
            return best, False
        w = _difference(pts_a, a0, a1, fa, pts_b, b0, b1, fb, b, body, shrink, P, R, v[0], v[1], v[2])
        vw = _dot(v, w)
        best = max(best, vw / math.sqrt(vv))
        if best > enough or vv - vw <= CONVERGED * vv:
            return best, False
        if count == 1:
            v, mask = _segment(w0, w)
        elif count == 2:
            v, mask = _triangle(w0, w1, w)
        else:
            v, mask = _tetrahedron(w0, w1, w2, w)
            if mask == 15:
                return best, True
        w3 = w
        count, kept = 0, (w0, w1, w2, w3) if count == 3 else ((w0, w1, w, w) if count == 2 else (w0, w, w, w))
        for i in range(4):
            if mask & (1 << i):
                if count == 0:
                    w0 = kept[i]
                elif count == 1:
                    w1 = kept[i]
                else:
                    w2 = kept[i]
                count += 1
    return best, False


@njit(cache=True, nogil=True, inline="always")
def separation(s: Shapes, b: Bodies, pa: int, fa: int, pb: int, fb: int, P: Array, R: Array, u: Array,
               enough: float, least: float) -> float:
    """A lower bound of the distance between the hulls of parts ``pa`` (frame ``fa``) and ``pb`` (frame
    ``fb``), by their ``verts`` (few, holding the parts; ``gjk``; ``b`` unused)."""
    return gjk(s.verts, s.vert_first[pa], s.vert_end[pa], fa, s.verts, s.vert_first[pb], s.vert_end[pb], fb,
               b, -1, 0.0, P, R, u, enough, least)[0]


@njit(cache=True, nogil=True, inline="always")
def hull_separation(s: Shapes, b: Bodies, pa: int, fa: int, pb: int, fb: int, P: Array, R: Array, u: Array,
                    enough: float, least: float) -> float:
    """``separation`` by the vertices of the parts' convex hulls (``hull``: Bullet's own shapes of them,
    many more): exact where GJK converges."""
    return gjk(s.hull, s.hull_first[pa], s.hull_end[pa], fa, s.hull, s.hull_first[pb], s.hull_end[pb], fb,
               b, -1, 0.0, P, R, u, enough, least)[0]


@njit(cache=True, nogil=True, inline="always")
def toward(s: Shapes, b: Bodies, p: int, f: int, k: int, P: Array, R: Array, u: Array) -> None:
    """``u``: from the centre of part ``p``'s box (frame ``f``) to body ``k``'s centre, where GJK starts."""
    for r in range(3):
        u[r] = b.centre[k, r] - (P[f, r] + R[f, r, 0] * s.box_c[p, 0] + R[f, r, 1] * s.box_c[p, 1]
                                 + R[f, r, 2] * s.box_c[p, 2])


@njit(cache=True, nogil=True, inline="always")
def part_body_gap(s: Shapes, b: Bodies, p: int, f: int, k: int, P: Array, R: Array, u: Array, enough: float,
                  least: float, exact: bool) -> float:
    """A lower bound of the distance between part ``p`` (frame ``f``) and body ``k`` (``gjk``): by the few
    ``verts`` holding the part, or with ``exact`` by the vertices of its convex hull (``hull``: Bullet's own
    shape of it, many more)."""
    if exact:
        return gjk(s.hull, s.hull_first[p], s.hull_end[p], f, s.hull, 0, 0, -1, b, k, 0.0, P, R, u, enough,
                   least)[0]
    return gjk(s.verts, s.vert_first[p], s.vert_end[p], f, s.verts, 0, 0, -1, b, k, 0.0, P, R, u, enough,
               least)[0]


@njit(cache=True, nogil=True, inline="always")
def sunk(s: Shapes, b: Bodies, p: int, f: int, k: int, P: Array, R: Array, depth: float, u: Array,
         exact: bool) -> bool:
    """Part ``p`` (frame ``f``), a part whose points are its own (``own``), reaches more than ``depth`` into
    body ``k``, an exact one (a primitive): the convex hull of points of the part (its ``corners``, few, or
    with ``exact`` the vertices of its hull, many) meets the body shrunk by ``depth`` (every point of which
    lies more than ``depth`` inside it, so that no move shorter than ``depth`` parts them). ``u``:
    scratch."""
    if p < 0 or not b.exact[k] or not s.own[p]:
        return False
    size = b.size[k]
    thin = min(size[0], size[1]) if b.kind[k] == 2 else size[0]
    if b.kind[k] == 0:
        thin = min(thin, min(size[1], size[2]))
    if not thin > depth:
        return False
    toward(s, b, p, f, k, P, R, u)
    if exact:
        return gjk(s.hull, s.hull_first[p], s.hull_end[p], f, s.hull, 0, 0, -1, b, k, depth, P, R, u, 0.0,
                   -1.0)[1]
    return gjk(s.corners, s.vert_first[p], s.vert_end[p], f, s.corners, 0, 0, -1, b, k, depth, P, R, u, 0.0,
               -1.0)[1]
