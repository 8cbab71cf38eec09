"""Compiled kernels of the self pairs (``bounds_kernel.classify``): a pair's table (``pair_tables.py``'s
``PairTables``, ``sphere_kernel.py`` says what each array holds) filled and looked up, else its links'
parts by balls, boxes (separating axes) and hulls (``gjk_kernel.separation``). Compiled by numba and
cached on disk as ``sphere_kernel.py``'s, without reference counting (``sphere_kernel.kernel``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from robwot_sim.sim.gjk_kernel import hull_separation, separation
from robwot_sim.sim.sphere_kernel import frames, kernel, place

if TYPE_CHECKING:
    from robwot_sim.sim.joint_tree import Tree
    from robwot_sim.sim.outerbounds import Bodies
    from robwot_sim.sim.pair_tables import PairTables
    from robwot_sim.sim.robot_shapes import Shapes

Array = np.ndarray


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


@kernel
def _pair_gap(s: Shapes, b: Bodies, la: int, fa: int, lb: int, fb: int, P: Array, R: Array, cap: float,
              floor: float, exact: bool, ca: Array, cb: Array, u: Array) -> float:
    """A lower bound of the distance between links ``la`` (frame ``fa``) and ``lb``'s hulls in the frames
    ``P``, ``R``, at most ``cap``: per pair of their parts the distance of their balls or, where that is
    below the bound so far, the larger of it and GJK's on their few vertices (``separation``) or, with
    ``exact`` where that is too, on their whole hulls (``hull_separation``: the exact distance where GJK
    converges); returned as soon as two parts are found within ``floor`` (any bound at or below it then
    tells the same). ``ca``, ``cb``: scratch."""
    best = cap
    for pa in range(s.part_first[la], s.part_end[la]):
        place(P, R, fa, s.box_c[pa], ca)
        for pb in range(s.part_first[lb], s.part_end[lb]):
            place(P, R, fb, s.box_c[pb], cb)
            for r in range(3):
                u[r] = cb[r] - ca[r]
            d = float(math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) - s.box_r[pa] - s.box_r[pb])
            if d >= best:
                continue
            d = max(d, separation(s, b, pa, fa, pb, fb, P, R, u, best, floor))
            if exact and d < best and s.hull_end[pa] > s.hull_first[pa] and s.hull_end[pb] > s.hull_first[pb]:
                d = max(d, hull_separation(s, b, pa, fa, pb, fb, P, R, u, best, floor))
            best = min(best, d)
            if best <= floor:
                return best
    return best


@njit(cache=True, nogil=True, inline="always")
def _cell(tab: PairTables, k: int, q: Array) -> tuple[int, float]:
    """Configuration ``q``'s cell in self pair ``k``'s table (-1: no table, or outside it) and the rates
    times ``q``'s distance from the cell's centre per coordinate."""
    dims = tab.dims[k]
    if dims < 0:
        return -1, 0.0
    index, slack = 0, 0.0
    for m in range(dims):
        x = (q[tab.coord[k, m]] - tab.lo[k, m]) / tab.width[k, m]
        if not (x >= 0.0 and x < tab.cells[k, m]):
            return -1, 0.0
        c = int(x)
        index = index * tab.cells[k, m] + c
        slack += tab.rate[k, m] * tab.width[k, m] * abs(x - c - 0.5)
    return index, slack


@njit(cache=True, nogil=True, inline="always")
def _span(tab: PairTables, k: int) -> tuple[int, float]:
    """Self pair ``k``'s table: its number of cells (0: none) and the most ``_cell``'s slack can be."""
    if tab.dims[k] < 0:
        return 0, 0.0
    count, most = 1, 0.0
    for m in range(tab.dims[k]):
        count *= tab.cells[k, m]
        most += tab.rate[k, m] * tab.width[k, m] * 0.5
    return count, most


@njit(cache=True, nogil=True, inline="always")
def table_apart(tab: PairTables, k: int, q: Array, need: float) -> int:
    """Whether self pair ``k``'s links are more than ``need`` apart at configuration ``q`` by the pair's
    table (the bound of ``q``'s cell less the rates times ``q``'s distance from its centre): 1 yes, 0 not
    known (no table, outside it), -1 the cell not computed yet (``fill_cell``)."""
    index, slack = _cell(tab, k, q)
    if index < 0:
        return 0
    gap = tab.gap[tab.first[k] + index]
    if math.isnan(gap):
        return -1
    return 1 if gap - slack > need else 0


@kernel
def _gap_at(tab: PairTables, k: int, index: int, t: Tree, s: Shapes, b: Bodies, need: float, most: float,
            Q: Array, P: Array, R: Array, ca: Array, cb: Array, u: Array) -> float:
    """Cell ``index`` of self pair ``k``'s table computed and stored: ``_pair_gap`` at its centre (``Q``
    with the pair's coordinates moved there), at most what any point of the cell needs (``need`` plus
    ``most``), exact for a table over one coordinate (its cells are fine enough for a few millimetres to
    matter; a table over two has cells whose slack is larger than what exactness adds); ``P``, ``R`` and
    the rest scratch."""
    rest = index
    for m in range(tab.dims[k] - 1, -1, -1):
        Q[tab.coord[k, m]] = tab.lo[k, m] + (rest % tab.cells[k, m] + 0.5) * tab.width[k, m]
        rest //= tab.cells[k, m]
    frames(t, Q, P, R)
    n = t.parent.shape[0]
    la, lb = s.pair_a[k], s.pair_b[k]
    fa, fb = s.joint[la] if s.joint[la] >= 0 else n, s.joint[lb] if s.joint[lb] >= 0 else n
    gap = _pair_gap(s, b, la, fa, lb, fb, P, R, need + most, need, tab.dims[k] == 1, ca, cb, u)
    tab.gap[tab.first[k] + index] = gap
    return gap


@kernel
def fill_cell(tab: PairTables, k: int, q: Array, t: Tree, s: Shapes, b: Bodies, need: float, Q: Array,
              P: Array, R: Array, ca: Array, cb: Array, u: Array) -> int:
    """``table_apart`` once configuration ``q``'s cell is computed (``_gap_at``, from ``q``)."""
    index, slack = _cell(tab, k, q)
    most = _span(tab, k)[1]
    for m in range(q.shape[0]):
        Q[m] = q[m]
    gap = _gap_at(tab, k, index, t, s, b, need, most, Q, P, R, ca, cb, u)
    return 1 if gap - slack > need else 0


@njit(cache=True, nogil=True)
def fill_tables(t: Tree, s: Shapes, tab: PairTables, b: Bodies, need: float) -> None:
    """Every cell of every self pair's table not computed yet computed now (``_gap_at``)."""
    n = t.parent.shape[0]
    Q, P, R = np.zeros(t.coupling.shape[1]), np.empty((n + 1, 3)), np.empty((n + 1, 3, 3))
    ca, cb, u = np.empty(3), np.empty(3), np.empty(3)
    for k in range(tab.dims.shape[0]):
        count, most = _span(tab, k)
        for index in range(count):
            if math.isnan(tab.gap[tab.first[k] + index]):
                _gap_at(tab, k, index, t, s, b, need, most, Q, P, R, ca, cb, u)


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
            place(P, R, f, s.box_c[m], BC[m])
        dx, dy, dz = BC[m, 0] - bc[other, 0], BC[m, 1] - bc[other, 1], BC[m, 2] - bc[other, 2]
        lim = s.box_r[m] + s.link_r[other] + hull_gap + tolerance
        if dx * dx + dy * dy + dz * dz <= lim * lim:
            near[count] = m
            count += 1
    return count


@kernel
def pair_apart(s: Shapes, b: Bodies, la: int, fa: int, lb: int, fb: int, row: int, P: Array, R: Array,
                bc: Array, BC: Array, BA: Array, placed: Array, turned: Array, near_a: Array, near_b: Array,
                hull_gap: float, tolerance: float, r33: Array, a33: Array, u: Array) -> bool:
    """Every part of link ``la`` (frame ``fa``; its ball's centre in the world ``bc[la]``) more than
    ``hull_gap`` from every part of ``lb``: of the parts of each that come near the other link's ball,
    every pair's balls apart, else their boxes grown by half the gap, else their hulls (``separation``). A
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
            need = hull_gap + tolerance
            if not separation(s, b, pa, fa, pb, fb, P, R, u, need, need) > need:
                return False
    return True

