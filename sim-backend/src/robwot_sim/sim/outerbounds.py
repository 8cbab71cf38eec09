"""Outer bounds: configurations whose collision-freedom (or collision) is certain from geometry alone, found
for a whole batch by compiled kernels (``sphere_kernel.py``), so that Bullet checks only the others.

What they know of the robot itself (its joint tree, spheres, boxes and hulls of its parts, balls inside
them) is built once per robot body (``robot_shapes.py``). Every other body is exact where it is a
primitive obstacle (box, sphere, cylinder) and its Bullet bounding box otherwise (mesh obstacles; the
links of other robots, which stand still during a check). Per configuration the kernel runs the forward
kinematics of the whole joint tree (couplings applied) and places the shapes; a configuration is

- apart from every other body (`OuterBounds.apart`) when every sphere of a moving link keeps more than
  ``margin`` (the clearance a path check keeps; 0 for labels) from every other body, by a grid of the
  three least distances to the bodies per voxel (``distance_grid``; a whole link first by a coarse grid
  and the ball holding its spheres; a sphere farther from the voxel's centre than the least distance
  allows is clear; otherwise, where only one or two bodies can be that close, the sphere's part's hull
  against each): Bullet reports no contact with them, nor a body within the margin;
- free of self-contact (`OuterBounds.self_free`) when every part of one link of a pair Bullet checks
  (neither the other's parent, not a filtered pair) is more than ``HULL_GAP`` from every part of the
  other: their balls or boxes (separating-axis test) are apart, or a direction is found along which
  their hulls' vertices are that far apart (found by Gilbert's iteration, proven by the vertices);
- a sure hit when a ball inside a moving link's part reaches more than ``surehit.DEPTH`` into a
  primitive obstacle or into a ball of a link of a pair Bullet checks (``surehit.py``'s test, compiled),
  or a corner of the part found near a primitive obstacle (a point of the part nearest to a vertex of its
  slim hull) lies more than that inside it.

A row apart from every other body needs Bullet only for its self-contact, checked in a world holding the
robot alone; a row free both ways, or a sure hit, needs no Bullet (``CollisionQueries.free_batch``). A
path check asks Bullet only about the states not free for sure (``CollisionChecker.sure_free``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
import pybullet as pb

from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.kernels import asked, kernels_loaded, kernels_ready
from robwot_sim.sim.robot_shapes import GROW, RobotShapes, ball, robot_shapes
from robwot_sim.sim.surehit import DEPTH
from robwot_sim.sim.types import FloatArray

#: m two parts' hulls must be apart for their link pair to be free of self-contact: both margins, and 1 mm
HULL_GAP = 0.003
MAX_MARGIN = 0.05  # m: the largest margin the grid answers for (a larger one: nothing apart)
GRID_SIDE = 0.01  # m: the distance grid's finest voxel side
ZONE_SIDE = 0.05  # m: voxel side of the coarse grid that finds whole links clear
GRID_VOXELS = 1 << 20  # voxels of a distance grid at most (3 x 4 + 2 x 4 bytes each)
TOLERANCE = 1e-5  # m: above the float32 rounding of the grid's distances and the FK's
SURE_HIT = 4  # ``OuterBounds.classify``: the row surely collides

BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.int64]


# the kernels' arguments (``sphere_kernel.py`` says what each holds)
class Bodies(NamedTuple):
    kind: IntArray
    size: FloatArray
    centre: FloatArray
    rotation: FloatArray
    exact: BoolArray


class Grid(NamedTuple):
    lo: FloatArray
    side: float
    shape: IntArray
    d: npt.NDArray[np.float32]
    near: npt.NDArray[np.int32]
    bodies_lo: FloatArray
    bodies_hi: FloatArray


#: Bullet checks of the robot's current state timed after its bounds are built: what a state costs Bullet,
#: weighed against building stale bounds anew
PROBES = 5

def distance_grid(bodies: Bodies, reach: float, clip: tuple[FloatArray, FloatArray] | None,
                  side: float) -> Grid:
    """The grid of ``bodies`` (``sphere_kernel.Grid``) over the voxels within ``reach`` (the largest
    sphere radius plus margin asked about) plus a voxel's side of one, at most the box ``clip`` (the
    robot's reach), voxels of ``side`` or larger so that it holds at most ``GRID_VOXELS``."""
    from robwot_sim.sim.sphere_kernel import fill_grid

    kind, size, rot = bodies.kind, bodies.size, bodies.rotation
    turn = np.abs(rot)  # the body's axes are the columns of its rotation's transpose: world extents
    box = np.einsum("bji,bj->bi", turn.transpose(0, 2, 1), size)
    axis = turn[:, :, 2]
    cyl = axis * size[:, 1:2] + size[:, 0:1] * np.sqrt(np.maximum(0.0, 1.0 - axis * axis))
    half = np.where((kind == 0)[:, None], box, np.where((kind == 1)[:, None], size[:, :1].repeat(3, 1), cyl))
    for _ in range(2):  # the voxel side from the extent, the extent from the side
        # a voxel whose centre is farther than reach + side from a body needs no distance to it: no
        # point within the voxel comes within the reach of it
        low, high = bodies.centre - half - reach - side, bodies.centre + half + reach + side
        if not len(kind):
            bodies_lo, bodies_hi = np.full(3, np.inf), np.full(3, -np.inf)
            lo, hi = np.zeros(3), np.zeros(3)
        else:
            bodies_lo, bodies_hi = low.min(axis=0), high.max(axis=0)
            lo, hi = bodies_lo.copy(), bodies_hi.copy()
            if clip is not None:
                lo, hi = np.maximum(lo, clip[0]), np.minimum(hi, clip[1])
        extent = np.maximum(hi - lo, 0.0)
        side = max(side, float(np.prod(extent) / GRID_VOXELS) ** (1 / 3))
    shape = np.maximum(1, np.ceil(extent / side)).astype(np.int64)
    count = int(np.prod(shape))
    grid = Grid(lo, side, shape, np.full((count, 3), np.inf, dtype=np.float32),
                np.full((count, 2), -1, dtype=np.int32), bodies_lo, bodies_hi)
    if len(kind):
        fill_grid(grid, bodies, low, high)
    return grid


Body = tuple[int, FloatArray, FloatArray, FloatArray]


def _body(kind: int, size: Any, centre: Any, rotation: FloatArray) -> Body:
    out = np.zeros(3)
    values = np.asarray(size, dtype=np.float64).ravel()
    out[:len(values)] = values
    return kind, out, np.asarray(centre, dtype=np.float64).reshape(3), rotation


def spec_body(spec: dict[str, Any]) -> Body:
    """A primitive obstacle spec as a body of the grid."""
    shape, rot = spec["shape"], quat_matrix(spec["orientation"])
    if shape["type"] == "box":
        return _body(0, np.asarray(shape["size"], dtype=np.float64) / 2, spec["position"], rot)
    if shape["type"] == "sphere":
        return _body(1, [float(shape["radius"])], spec["position"], rot)
    return _body(2, [float(shape["radius"]), float(shape["length"]) / 2], spec["position"], rot)


def aabb_body(lo: Any, hi: Any) -> Body:
    """A bounding box (world axes) as a body of the grid."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    return _body(0, (hi - lo) / 2, (lo + hi) / 2, np.eye(3))


class OuterBounds:
    """The free-for-sure tests of one robot (module docstring) in one world: the robot's shapes and the
    grids of every other body. Empty (nothing known) without shapes."""

    def __init__(self, robot: RobotShapes | None = None, bodies: Bodies | None = None,
                 grid: Grid | None = None, zone: Grid | None = None) -> None:
        self.robot, self.bodies, self.grid, self.zone = robot, bodies, grid, zone
        self.links = list(robot.links) if robot else []
        self.pairs = list(robot.pairs) if robot else []
        self._compiled: Callable[..., int] | None = None  # ``_call``

    @property
    def empty(self) -> bool:
        return self.robot is None or not self.links

    def classify(self, qs: FloatArray, margin: float = 0.0, self_always: bool = True,
                 hits: bool = False) -> npt.NDArray[np.int8]:
        """Per row of ``qs`` (validated): 0 free for sure; bit 1 set where a moving link may come within
        ``margin`` (m) of another body; bit 2 where a checked self pair may touch (for every row, or with
        ``self_always`` false only for the rows apart from the other bodies); with ``hits``, ``SURE_HIT``
        where it surely collides (``surehit.py``'s test, compiled). Empty bounds, or a margin above
        ``MAX_MARGIN``: 3 everywhere."""
        return self._classify(qs, margin, self_always, hits, 0)[0]

    def free_ahead(self, qs: FloatArray, margin: float, unsure: int) -> tuple[BoolArray, int]:
        """The rows of ``qs`` free for sure by ``margin`` (``classify`` 0), tested in order until ``unsure``
        rows not known free are met (0: every row), and how many rows were tested (the rows after them
        are not known free)."""
        out, tested = self._classify(qs, margin, True, False, unsure)
        return out == 0, tested

    def _classify(self, qs: FloatArray, margin: float, self_always: bool, hits: bool,
                  stop: int) -> tuple[npt.NDArray[np.int8], int]:
        out = np.full(len(qs), 3, dtype=np.int8)
        if self.empty or margin > MAX_MARGIN or not len(qs):
            return out, len(qs)
        assert self.robot is not None and self.bodies is not None
        assert self.grid is not None and self.zone is not None
        rows = np.require(qs, np.float64, ["C", "W"])  # one array type: ``_call``
        assert rows.ndim == 2
        r = self.robot
        tested = self._call(rows, r.tree, r.shapes, r.tables, self.bodies, self.grid, self.zone,
                            float(margin), GROW, HULL_GAP, TOLERANCE, bool(self_always), bool(hits), DEPTH,
                            int(stop), out)
        return out, tested

    def _call(self, *args: Any) -> int:
        """``bounds_kernel.classify(*args)``: after its first call, its machine code for these arguments'
        types called directly. numba's dispatcher types every argument at every call, the shapes' dozens
        of arrays included: more time than the kernel takes for a short segment's states. The types of
        an instance's arguments never change (its arrays; the batch and the output contiguous arrays of
        fixed dtype; Python floats, bools and ints); the dispatcher stays the way where numba has no
        compiled code of these types to name."""
        from robwot_sim.sim.bounds_kernel import classify

        if self._compiled is not None:
            return self._compiled(*args)
        tested = int(classify(*args))
        compiled = getattr(classify, "overloads", {}).get(tuple(classify.typeof_pyval(a) for a in args))
        self._compiled = getattr(compiled, "entry_point", None) or classify
        return tested

    def fill_tables(self) -> None:
        """Every cell of the robot's self pair tables computed now (``pair_tables.PairTables``) instead of
        as configurations fall in them: a servient's warm-up, off the world's thread (a cell is written
        once, with the value any writer computes, so classifying meanwhile is safe)."""
        if self.empty:
            return
        from robwot_sim.sim.pair_kernel import fill_tables

        assert self.robot is not None and self.bodies is not None
        fill_tables(self.robot.tree, self.robot.shapes, self.robot.tables, self.bodies, HULL_GAP + TOLERANCE)

    def apart(self, qs: FloatArray, margin: float = 0.0) -> BoolArray:
        """True where every moving link keeps more than ``margin`` (m) from every other body, for sure."""
        return np.asarray(self.classify(qs, margin, self_always=False) & 1 == 0)

    def self_free(self, qs: FloatArray) -> BoolArray:
        """True where no self pair Bullet checks can touch, for sure."""
        return np.asarray(self.classify(qs) & 2 == 0)


def build_outer_bounds(robot: RobotShapes | None, cid: int, obstacles: list[tuple[int, dict[str, Any]]],
                       others: list[Any]) -> OuterBounds:
    """The free-for-sure tests of a robot (its ``robot_shapes``; None: empty bounds) in a world of
    ``obstacles`` (body id, spec) and other robots (``BoundRobot``, at their current state)."""
    if robot is None:
        return OuterBounds()
    exact = [spec["shape"]["type"] in ("box", "sphere", "cylinder") for _, spec in obstacles]
    found = [spec_body(spec) if sure else aabb_body(*pb.getAABB(ob_body, -1, physicsClientId=cid))
             for (ob_body, spec), sure in zip(obstacles, exact, strict=True)]
    for other in others:
        for ln in range(-1, pb.getNumJoints(other.body, physicsClientId=cid)):
            if pb.getCollisionShapeData(other.body, ln, physicsClientId=cid):
                found.append(aabb_body(*pb.getAABB(other.body, ln, physicsClientId=cid)))
                exact.append(False)
    bodies = Bodies(np.array([b[0] for b in found], dtype=np.int64),
                    np.array([b[1] for b in found]).reshape(-1, 3),
                    np.array([b[2] for b in found]).reshape(-1, 3),
                    np.array([b[3] for b in found]).reshape(-1, 3, 3),
                    np.array(exact, dtype=np.bool_))
    margin = max((float(lk.radii.max()) for lk in robot.links if len(lk.radii)), default=0.0) + MAX_MARGIN
    base = robot.tree.base_p
    clip = None if robot.reach is None else (base - robot.reach - margin, base + robot.reach + margin)
    zone = max((ball(lk.centres, lk.radii)[1] for lk in robot.links), default=0.0) + MAX_MARGIN
    return OuterBounds(robot, bodies, distance_grid(bodies, margin, clip, GRID_SIDE),
                       distance_grid(bodies, zone, clip, ZONE_SIDE))


class BoundsCache:
    """The outer bounds of a scene's robots: what the bounds know of each robot itself kept per robot body,
    the bounds kept while nothing but the robot's own joints changes (``Scene.others_stamp``)."""

    def __init__(self) -> None:
        self._bounds: dict[str, tuple[tuple[int, int], OuterBounds]] = {}
        self._shapes: dict[str, tuple[Any, RobotShapes | None]] = {}
        self._rent: dict[str, float] = {}  # per robot: states whose Bullet checks cost its last build
        self._stale: dict[str, int] = {}  # per robot: states checked on Bullet alone since they went stale

    def get(self, scene: Any, robot_id: str, rows: int = 0) -> OuterBounds:
        """Robot ``robot_id``'s bounds in ``scene`` (a ``planning_scene.Scene``), asked for ``rows``
        configurations (``asked``); empty (nothing known) until the process has asked about enough of them
        and the compiled kernels are loaded (``kernels.load_kernels``)."""
        if not asked(rows) or not kernels_ready():
            return OuterBounds()
        stamp = scene.others_stamp(robot_id)
        cached = self._bounds.get(robot_id)
        if cached is not None and cached[0] == stamp:
            return cached[1]
        entries = scene.entries()
        e = entries[robot_id]
        known = self._shapes.get(robot_id)
        if known is None or known[0] is not e:
            known = (e, robot_shapes(e.bound, e.checker.filtered, e.model))
            self._shapes[robot_id] = known
        others = [o.bound for rid, o in entries.items() if rid != robot_id]
        start = time.perf_counter()
        bounds = build_outer_bounds(known[1], scene.bullet.cid, scene.obstacle_bodies(), others)
        built = time.perf_counter()
        for _ in range(PROBES):  # what Bullet takes for one state of this robot in this world
            e.checker.is_free(e.clearance)
        per_state = max((time.perf_counter() - built) / PROBES, 1e-7)
        self._rent[robot_id] = (built - start) / per_state
        self._bounds[robot_id] = (stamp, bounds)
        return bounds

    def _worth_building(self, scene: Any, robot_id: str, states: int) -> bool:
        """Whether a check of ``states`` may use the robot's bounds, building them anew if the world changed:
        yes when they are current or were never built; else only once the states checked on Bullet alone
        since they went stale have cost Bullet what their last build took (rent until the rent paid equals
        the price: never more than twice the cost of either choice). A world that keeps changing (another
        robot moving, objects on a belt) so leaves short checks to Bullet instead of building the bounds
        for each; a world changed once pays a few checks' worth of rent."""
        cached = self._bounds.get(robot_id)
        if cached is None or cached[0] == scene.others_stamp(robot_id):
            return True
        spent = self._stale.get(robot_id, 0) + states
        if spent < self._rent.get(robot_id, 0.0):
            self._stale[robot_id] = spent
            return False
        self._stale[robot_id] = 0
        return True

    def sure_free(self, scene: Any, robot_id: str, entry: Any, qs: FloatArray, clearance: float,
                  unsure: int = 0) -> tuple[BoolArray, int]:
        """The states of robot ``robot_id``'s body ``entry`` (a ``loader.RobotEntry``) its bounds find farther
        than ``clearance`` from every other body and free of self-contact, tested in order until ``unsure``
        states not known free are met (0: all), and how many were tested (``CollisionChecker.sure_free``);
        none until the kernels are loaded (path checks never load them: ``kernels.WARM_AFTER``), while
        ``entry`` is not the robot's (a body being rebuilt) or a link fixed to its base touches something
        (every state then collides)."""
        if not kernels_loaded() or scene.entries().get(robot_id) is not entry \
                or entry.checker.static_contacts() or not self._worth_building(scene, robot_id, len(qs)):
            return np.zeros(len(qs), dtype=bool), len(qs)
        return self.get(scene, robot_id).free_ahead(qs, clearance, unsure)
