"""Compiled kernels of the outer bounds (``outerbounds.py``): forward kinematics of a whole joint tree and
the tests of one configuration after another, and the distance grids they look up.

Compiled by numba on first use and cached on disk (``cache=True``: next to this file, or numba's user-wide
cache where that is not writable), so a later process loads them instead of compiling. The kernels are
generic: a robot is arrays (its joint tree, its shapes, its link pairs), never code of its own.

A kernel that is called (``kernel``, not inlined) is compiled without numba's reference counting
(``_nrt=False``): with it, every array a kernel views or passes to an inlined function (each array of a
named tuple, each row taken as ``a[k]``) is counted up and down by an atomic operation, many per test, and
those operations cost several times the tests themselves. Such a kernel allocates nothing and returns no
array: its caller passes the scratch arrays, made by a function compiled with counting.

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
vertices (``verts[vert_first[p]:vert_end[p]]``; ``corners`` beside them: the part's own point nearest to
each, where ``own[p]``: a sphere's or capsule's are its box's), the planes of its convex hull's faces
(``faces[face_first[p]:face_end[p]]``: unit outward normal, offset) and that hull's vertices
(``hull[hull_first[p]:hull_end[p]]``: Bullet's own shape of the part, many more), the parts of link ``l``
``part_first[l]``..``part_end[l]``
inside the ball ``link_c``/``link_r``, for the self pairs ``pair_a[k]``, ``pair_b[k]`` (``pair_hit[k]``: one
Bullet reports contacts of, a link of it with mass: the fixed base's pairs too). Balls inside
the link's parts (``surehit.py``: ``inner_c``/``inner_r``, link ``l``: ``inner_first[l]``..
``inner_end[l]``, largest first) for sure hits (``hit_kernel.py``), against exact bodies (``Bodies.exact``:
primitives, not the bounding boxes of meshes and other robots) and in the pairs with ``pair_hit``.

``PairTables``, per self pair ``k`` with ``dims[k]`` >= 0 (-1: none): the coordinates ``coord[k, :dims]``
its links' relative pose depends on, their cells from ``lo[k, m]``, ``width[k, m]`` wide, ``cells[k, m]``
of them (C order), ``rate[k, m]`` (m per unit) the farthest a hull vertex of either link moves per unit of
the coordinate, and from ``gap[first[k]]`` on per cell a lower bound of the distance between the two
links' hulls at the cell's centre (NaN until computed).

``Bodies``: the other bodies, ``kind`` 0 box (half sizes), 1 sphere (radius), 2 cylinder (radius, half
length along its z), ``centre``, ``rotation`` (world -> its frame: ``(p - centre) @ rotation``).

``Grid``: over voxels of ``side`` from corner ``lo`` (C order, ``shape``), the three least signed
distances from a voxel's centre to a body (``d[v]``, float32, +inf where none is within the grid's reach)
and the bodies of the two least (``near[v]``, -1: none); ``bodies_lo``..``bodies_hi``: the bodies'
box grown by that reach (a point outside it is farther than the reach from every body).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numpy as np
from numba import njit

if TYPE_CHECKING:
    from robwot_sim.sim.joint_tree import Tree
    from robwot_sim.sim.outerbounds import Bodies, Grid

_Function = TypeVar("_Function", bound=Callable[..., object])


def kernel(function: _Function) -> _Function:
    """``function`` compiled as a called kernel is (module docstring; ``_nrt`` is not in numba's type
    stubs)."""
    options: dict[str, Any] = {"cache": True, "nogil": True, "_nrt": False}
    return cast(_Function, njit(**options)(function))

Array = np.ndarray


@njit(cache=True, nogil=True, inline="always")
def body_sdf(b: Bodies, k: int, x: float, y: float, z: float) -> float:
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


@njit(cache=True, nogil=True, inline="always")
def _cells(low: float, high: float, lo: float, side: float, count: int) -> tuple[int, int]:
    """The first and end index of the cells of ``side`` from ``lo`` (``count`` of them) that ``low``..``high``
    overlaps."""
    first = min(max(math.floor((low - lo) / side), 0), count)
    return first, min(max(math.ceil((high - lo) / side), 0), count)


@kernel
def fill_grid(g: Grid, b: Bodies, low: Array, high: Array) -> None:
    """``g.d`` and ``g.near`` (filled with +inf and -1) over the voxels of each body's box ``low[k]``..
    ``high[k]`` (the body's box grown by the grid's reach)."""
    ny, nz = g.shape[1], g.shape[2]
    for k in range(b.kind.shape[0]):
        a0, e0 = _cells(low[k, 0], high[k, 0], g.lo[0], g.side, g.shape[0])
        a1, e1 = _cells(low[k, 1], high[k, 1], g.lo[1], g.side, g.shape[1])
        a2, e2 = _cells(low[k, 2], high[k, 2], g.lo[2], g.side, g.shape[2])
        for i in range(a0, e0):
            x = g.lo[0] + (i + 0.5) * g.side
            for j in range(a1, e1):
                y = g.lo[1] + (j + 0.5) * g.side
                for m in range(a2, e2):
                    s = np.float32(body_sdf(b, k, x, y, g.lo[2] + (m + 0.5) * g.side))
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


@kernel
def frames(t: Tree, q: Array, P: Array, R: Array) -> None:
    """Every joint's frame for configuration ``q`` into ``P`` (n + 1, 3) and ``R`` (n + 1, 3, 3), the root's
    included."""
    n = t.parent.shape[0]
    for r in range(3):
        P[n, r] = t.base_p[r]
        for c in range(3):
            R[n, r, c] = t.base_r[r, c]
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
        m00, m01, m02 = 1.0 - c1 * (ay * ay + az * az), -s * az + c1 * ax * ay, s * ay + c1 * ax * az
        m10, m11, m12 = s * az + c1 * ax * ay, 1.0 - c1 * (ax * ax + az * az), -s * ax + c1 * ay * az
        m20, m21, m22 = -s * ay + c1 * ax * az, s * ax + c1 * ay * az, 1.0 - c1 * (ax * ax + ay * ay)
        for r in range(3):
            a0, a1, a2 = R[j, r, 0], R[j, r, 1], R[j, r, 2]
            R[j, r, 0] = a0 * m00 + a1 * m10 + a2 * m20
            R[j, r, 1] = a0 * m01 + a1 * m11 + a2 * m21
            R[j, r, 2] = a0 * m02 + a1 * m12 + a2 * m22


@njit(cache=True, nogil=True, inline="always")
def place(P: Array, R: Array, f: int, local: Array, out: Array) -> None:
    """Point ``local`` of frame ``f`` in the world, into ``out``."""
    for r in range(3):
        out[r] = P[f, r] + R[f, r, 0] * local[0] + R[f, r, 1] * local[1] + R[f, r, 2] * local[2]


UNKNOWN = -1


@njit(cache=True, nogil=True, inline="always")
def voxel_of(g: Grid, x: float, y: float, z: float) -> tuple[int, float]:
    """The voxel holding (x, y, z) and the point's distance to its centre, or (-1, 0) outside the grid."""
    gx, gy, gz = (x - g.lo[0]) / g.side, (y - g.lo[1]) / g.side, (z - g.lo[2]) / g.side
    if gx < 0.0 or gy < 0.0 or gz < 0.0 or gx >= g.shape[0] or gy >= g.shape[1] or gz >= g.shape[2]:
        return -1, 0.0
    ix, iy, iz = int(gx), int(gy), int(gz)
    ex, ey, ez = gx - ix - 0.5, gy - iy - 0.5, gz - iz - 0.5
    return (ix * g.shape[1] + iy) * g.shape[2] + iz, g.side * math.sqrt(ex * ex + ey * ey + ez * ez)


@njit(cache=True, nogil=True, inline="always")
def near(g: Grid, b: Bodies, x: float, y: float, z: float, need: float, exact: bool, tolerance: float,
          found: Array) -> int:
    """How many bodies may come within ``need`` of (x, y, z), written to ``found``: 0 outside the bodies'
    box, or where the voxel's least distance less the point's distance to the voxel's centre exceeds
    ``need`` (a distance changes no faster than the point); with ``exact``, the voxel's one or two nearest
    bodies where the next least distance bounds all others, those whose exact distance exceeds ``need``
    left out; else ``UNKNOWN`` (inside the bodies' box but outside the grid, too)."""
    if (x < g.bodies_lo[0] or y < g.bodies_lo[1] or z < g.bodies_lo[2]
            or x > g.bodies_hi[0] or y > g.bodies_hi[1] or z > g.bodies_hi[2]):
        return 0
    v, gap = voxel_of(g, x, y, z)
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
        if body_sdf(b, k, x, y, z) - tolerance <= need:
            found[count] = k
            count += 1
    return count if g.d[v, 2] - gap > need else UNKNOWN
