"""The compiled verdict of ``OuterBounds.classify`` per configuration: the other bodies (``sphere_kernel``),
the self pairs (``pair_kernel``), sure hits (``hit_kernel.sure``). Compiled by numba and cached on disk
as ``sphere_kernel.py``'s, whose docstring says what each array holds; the rows are tested by one kernel,
``_rows``, compiled without reference counting (``sphere_kernel.kernel``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from robwot_sim.sim.gjk_kernel import part_body_gap, sunk, toward
from robwot_sim.sim.hit_kernel import sunk_pair, sure
from robwot_sim.sim.outerbounds import SURE_HIT
from robwot_sim.sim.pair_kernel import fill_cell, pair_apart, table_apart
from robwot_sim.sim.sphere_kernel import UNKNOWN, body_sdf, frames, kernel, near, place

if TYPE_CHECKING:
    from robwot_sim.sim.joint_tree import Tree
    from robwot_sim.sim.outerbounds import Bodies, Grid
    from robwot_sim.sim.pair_tables import PairTables
    from robwot_sim.sim.robot_shapes import Shapes

Array = np.ndarray
#: (part, body) pairs a row leaves to the parts' whole hulls until every body is looked at, at most
PENDING = 8


@njit(cache=True, nogil=True)
def _scratch(n: int, parts: int, links: int, coords: int) -> tuple[Array, ...]:
    """``classify``'s scratch arrays for a tree of ``n`` joints, ``parts`` convex parts, ``links`` links."""
    return (np.empty((n + 1, 3)), np.empty((n + 1, 3, 3)), np.empty((links, 3)), np.empty((parts, 3)),
            np.empty((parts, 3, 3)), np.full(parts, -1, np.int64), np.full(parts, -1, np.int64),
            np.empty((3, 3)), np.empty((3, 3)), np.empty(parts, np.int64), np.empty(parts, np.int64),
            np.empty(coords), np.empty((n + 1, 3)), np.empty((n + 1, 3, 3)), np.empty((4, 3)),
            np.empty(2, np.int64), np.full(parts, -1, np.int64), np.full(parts, -1, np.int64),
            np.empty((PENDING, 3), np.int64))


@njit(cache=True, nogil=True)
def classify(qs: Array, t: Tree, s: Shapes, tab: PairTables, b: Bodies, grid: Grid, zone: Grid,
             margin: float, body_gap: float, hull_gap: float, tolerance: float, self_always: bool, hits: bool,
             depth: float, stop: int, out: Array) -> int:
    """Per row of ``qs``: bit 1 set where a sphere of a moving link may come within ``margin`` of a body
    (a link whose ball the coarse ``zone`` finds clear is not looked at further; a sphere by the fine
    ``grid``, exactly where one or two bodies only can be near, by each body's exact distance where more
    can, and then its part's hull kept more than ``body_gap`` plus the margin from them:
    ``_part_status``), bit 2 where two parts of a checked link pair may come within ``hull_gap`` (link
    balls, the pair's table, then part balls, boxes, hulls), for every row or (not ``self_always``) only
    the rows clear of the bodies (bit 2 then set untested). With ``hits``, a row not found free that
    surely collides (by more than ``depth``: ``_part_status``, ``sure``, or ``sunk_pair`` for the self
    pair found near or one after it) is 4 instead. With ``stop`` > 0 the rows after the ``stop``-th row not
    found free are left as they are in ``out``. Returns the number of rows tested."""
    scratch = _scratch(t.parent.shape[0], s.box_c.shape[0], s.joint.shape[0], qs.shape[1])
    return _rows(qs, t, s, tab, b, grid, zone, margin, body_gap, hull_gap, tolerance, self_always, hits,
                 depth, stop, out, scratch)


@njit(cache=True, nogil=True, inline="always")
def _part_status(s: Shapes, b: Bodies, p: int, f: int, k: int, P: Array, R: Array, u: Array, gap: float,
                 hits: bool, depth: float) -> int:
    """Part ``p`` (frame ``f``) against body ``k`` by the part's few points: 0 its slim hull more than ``gap``
    from it, with ``hits`` ``SURE_HIT`` where the hull of its corners reaches more than ``depth`` into it
    (``gjk_kernel.sunk``), else 1 (its whole hull may tell: ``part_body_gap``'s ``exact``). ``u``:
    scratch."""
    toward(s, b, p, f, k, P, R, u)
    if part_body_gap(s, b, p, f, k, P, R, u, gap, gap, False) > gap:
        return 0
    return SURE_HIT if hits and sunk(s, b, p, f, k, P, R, depth, u, False) else 1


@njit(cache=True, nogil=True, inline="always")
def _bodies(i: int, s: Shapes, b: Bodies, grid: Grid, zone: Grid, P: Array, R: Array, n: int, margin: float,
            gap: float, tolerance: float, hits: bool, depth: float, w: Array, u: Array,
            found: Array, kept: Array, pending: Array) -> tuple[int, int, int, int]:
    """Row ``i``'s verdict on the other bodies (``classify``'s bit 1, or ``SURE_HIT``) and the part, its
    frame and the body it concerns (-1: none). The pairs the parts' few points leave open wait in
    ``pending`` until every body is looked at (a later pair may be a sure hit), then their whole hulls
    decide (``kept``: per part, the row and body it was last looked at against)."""
    nb, waiting = b.kind.shape[0], 0
    for ln in range(s.joint.shape[0]):
        if not s.moving[ln]:
            continue
        f = s.joint[ln] if s.joint[ln] >= 0 else n
        place(P, R, f, s.ball_c[ln], w)
        if near(zone, b, w[0], w[1], w[2], s.ball_r[ln] + margin, False, tolerance, found) == 0:
            continue
        for k in range(s.sphere_first[ln], s.sphere_end[ln]):
            place(P, R, f, s.sphere_c[k], w)
            reach, p = s.sphere_r[k] + margin, s.sphere_part[k]
            count = near(grid, b, w[0], w[1], w[2], reach, True, tolerance, found)
            every = count == UNKNOWN  # the grid cannot tell: each body by its exact distance
            for j in range(nb if every else count):  # the sphere's part against each body it may reach
                m = j if every else found[j]
                apart = every and body_sdf(b, m, w[0], w[1], w[2]) - tolerance > reach
                if apart or kept[p] == i * nb + m:  # the sphere apart from it, or kept from it already
                    continue
                status = _part_status(s, b, p, f, m, P, R, u, gap, hits, depth)
                if status == SURE_HIT or (status and waiting == PENDING):
                    return status, p, f, m
                kept[p] = i * nb + m  # looked at once in this row: apart, or waiting below
                if status:
                    pending[waiting, 0], pending[waiting, 1], pending[waiting, 2] = p, f, m
                    waiting += 1
    for q in range(waiting):
        p, f, m = pending[q, 0], pending[q, 1], pending[q, 2]
        toward(s, b, p, f, m, P, R, u)
        if not part_body_gap(s, b, p, f, m, P, R, u, gap, gap, True) > gap:
            return 1, p, f, m
    return 0, -1, -1, -1


@kernel
def _rows(qs: Array, t: Tree, s: Shapes, tab: PairTables, b: Bodies, grid: Grid, zone: Grid, margin: float,
          body_gap: float, hull_gap: float, tolerance: float, self_always: bool, hits: bool, depth: float,
          stop: int, out: Array, scratch: tuple[Array, ...]) -> int:
    """``classify`` with its scratch arrays (``_scratch``)."""
    n, nl = t.parent.shape[0], s.joint.shape[0]
    P, R, bc, BC, BA, placed, turned, r33, a33, near_a, near_b, Q, P2, R2, v, found, seen, kept, wait = (
        scratch)
    # placed, turned, seen: the row whose BC, BA a part's are
    w, u, ca, cb = v[0], v[1], v[2], v[3]
    need = hull_gap + tolerance
    unsure = 0  # rows not found free so far
    stop = stop if stop > 0 else qs.shape[0] + 1
    for i in range(qs.shape[0]):
        frames(t, qs[i], P, R)
        gap = body_gap + margin + tolerance
        status, part, frame, body = _bodies(i, s, b, grid, zone, P, R, n, margin, gap, tolerance, hits,
                                            depth + tolerance, w, u, found, kept, wait)
        pair = -1
        if status == SURE_HIT:
            out[i] = status
            unsure += 1
            if unsure == stop:
                return i + 1
            continue
        if status == 0 or self_always:
            for ln in range(nl):
                place(P, R, s.joint[ln] if s.joint[ln] >= 0 else n, s.link_c[ln], bc[ln])
            for k in range(s.pair_a.shape[0]):
                la, lb = s.pair_a[k], s.pair_b[k]
                dx, dy, dz = bc[la, 0] - bc[lb, 0], bc[la, 1] - bc[lb, 1], bc[la, 2] - bc[lb, 2]
                if dx * dx + dy * dy + dz * dz > (s.link_r[la] + s.link_r[lb] + need) ** 2:
                    continue
                fa, fb = s.joint[la] if s.joint[la] >= 0 else n, s.joint[lb] if s.joint[lb] >= 0 else n
                known = table_apart(tab, k, qs[i], need)
                if known < 0:
                    known = fill_cell(tab, k, qs[i], t, s, b, need, Q, P2, R2, ca, cb, u)
                if not known and not pair_apart(s, b, la, fa, lb, fb, i, P, R, bc, BC, BA, placed, turned,
                                                 near_a, near_b, hull_gap, tolerance, r33, a33, u):
                    status |= 2
                    pair = k
                    break
        else:
            status = 3
        if status and hits:
            if sure(s, b, grid, P, R, n, bc, depth, tolerance, w, part, frame, body, seen, i):
                status = SURE_HIT
            while status != SURE_HIT and 0 <= pair < s.pair_a.shape[0]:  # the pair found near, those after
                if sunk_pair(s, pair, n, P, R, depth, tolerance, w, ca):
                    status = SURE_HIT
                pair += 1
        out[i] = status
        unsure += status != 0
        if unsure == stop:
            return i + 1
    return int(qs.shape[0])
