"""Per self pair of a robot whose links' relative pose depends on at most two joint coordinates (revolute
and prismatic joints between them, couplings included), a table over those coordinates (``PairTables``):
each cell will hold a lower bound of the distance between the two links' hulls at the cell's centre, filled
by the kernel the first time a configuration falls in the cell. A configuration elsewhere in the cell is
apart by that bound less how far its coordinates are from the centre times how fast a point of either
link can move per unit of each (``rate``: for a revolute joint the farthest hull vertex from the joint's
axis over every configuration, for a prismatic one 1 m per m), so most self pairs cost a lookup instead of
a test of their parts."""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from robwot_sim.sim.joint_tree import Tree, ancestors
from robwot_sim.sim.types import FloatArray

if TYPE_CHECKING:
    from robwot_sim.sim.robot_shapes import Shapes

#: m a hull vertex may move from a pair table cell's centre to its edge per coordinate, where the cells
#: allow, for tables over one coordinate and over two: finer cells prove pairs apart nearer to each other
#: (a gripper's knuckles, a few mm apart, moved by its one coordinate) but each is filled once (one test of
#: the pair's parts), and a table over two coordinates reaches ``MAX_CELLS`` long before
CELL_STEP = (0.0005, 0.01)
MAX_CELLS = 4096  # cells of one pair's table at most

IntArray = npt.NDArray[np.int64]


# the kernels' argument (``sphere_kernel.py`` says what each holds)
class PairTables(NamedTuple):
    dims: IntArray
    coord: IntArray
    lo: FloatArray
    width: FloatArray
    cells: IntArray
    rate: FloatArray
    first: IntArray
    gap: FloatArray


def pair_tables(tree: Tree, shapes: Shapes, lo: FloatArray, hi: FloatArray) -> PairTables:
    """The self pairs' tables (module docstring; ``sphere_kernel.PairTables``), every cell unknown (NaN), for
    coordinates within ``lo``..``hi``. A pair gets none (``dims`` -1) where more than two coordinates move
    its links or a coordinate's limits are not finite."""
    pairs = len(shapes.pair_a)
    dims, first = np.full(pairs, -1, dtype=np.int64), np.zeros(pairs, dtype=np.int64)
    coord, cells = np.zeros((pairs, 2), dtype=np.int64), np.ones((pairs, 2), dtype=np.int64)
    low, width, rate = np.zeros((pairs, 2)), np.ones((pairs, 2)), np.zeros((pairs, 2))
    radius = [max((float(np.linalg.norm(shapes.verts[shapes.vert_first[p]:shapes.vert_end[p]], axis=1).max())
                   for p in range(shapes.part_first[ln], shapes.part_end[ln])
                   if shapes.vert_end[p] > shapes.vert_first[p]), default=0.0)
              for ln in range(len(shapes.joint))]
    size = 0
    for k, (la, lb) in enumerate(zip(shapes.pair_a, shapes.pair_b, strict=True)):
        chains = [ancestors(tree, int(shapes.joint[la])), ancestors(tree, int(shapes.joint[lb]))]
        shared = set(chains[0]) & set(chains[1])
        speed: dict[int, float] = {}
        for link, chain in zip((la, lb), chains, strict=True):
            below = radius[link]  # how far the link's vertices lie from the joint's origin, on its axis
            for j in chain:
                if j in shared:
                    break
                terms = [(int(c), abs(float(tree.coupling[j, c]))) for c in np.flatnonzero(tree.coupling[j])]
                if tree.kind[j] == 2:  # every point moves along the unit axis by the joint's value
                    travel = abs(float(tree.offset[j])) + sum(f * max(abs(lo[c]), abs(hi[c]))
                                                              for c, f in terms)
                    for c, f in terms:
                        speed[c] = speed.get(c, 0.0) + f
                    below += travel  # NaN or inf where a limit is not finite: no table then
                elif tree.kind[j] == 1:
                    for c, f in terms:
                        speed[c] = speed.get(c, 0.0) + f * below
                below += float(np.linalg.norm(tree.origin_p[j]))
        coords = sorted(speed)
        if len(coords) > 2 or not all(np.isfinite([lo[c], hi[c], speed[c]]).all() for c in coords):
            continue
        per_dim = MAX_CELLS if len(coords) < 2 else int(MAX_CELLS ** 0.5)
        dims[k], first[k] = len(coords), size
        for m, c in enumerate(coords):
            span = max(float(hi[c] - lo[c]), 1e-9)
            count = int(min(max(np.ceil(span * speed[c] / (2 * CELL_STEP[len(coords) - 1])), 1), per_dim))
            coord[k, m], low[k, m], width[k, m], cells[k, m] = c, lo[c], span / count, count
            rate[k, m] = speed[c]
        size += int(np.prod(cells[k, :len(coords)]))
    return PairTables(dims, coord, low, width, cells, rate, first, np.full(size, np.nan))
