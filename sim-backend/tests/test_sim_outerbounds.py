"""Outer bounds (robwot_sim.sim.outerbounds, compiled kernels in sphere_kernel): every configuration they
call apart from the other bodies or free of self-contact is so for a fresh Bullet distance query (no
contact manifold kept from an earlier state), and the labels of World.collision_free_batch with them
equal Bullet's labels without them, on
bundled robots (primitives, meshes, mimic joints), a robot as published for ROS with its SRDF and a tool,
mesh obstacles and another robot in the scene. ``python -m robwot_bench.bounds`` runs the same on 10^5
configurations per robot."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pybullet as pb
import pytest
from numba import njit
from simhelp import MODELS

from robwot_bench.reference import example_robot
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.model.tool import attach_tool
from robwot_sim.sim import joint_tree, kernels, outerbounds, robot_shapes
from robwot_sim.sim.hit_kernel import _body_inside, sunk_pair
from robwot_sim.sim.outerbounds import HULL_GAP, TOLERANCE, OuterBounds
from robwot_sim.sim.robot_shapes import GROW
from robwot_sim.sim.sphere_kernel import frames, place
from robwot_sim.sim.surehit import DEPTH
from robwot_sim.sim.world import World

SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"


@pytest.fixture(autouse=True)
def loaded_kernels() -> None:
    """The compiled kernels loaded (or, on a machine's first use, compiled) before any bounds are asked."""
    assert kernels.kernels_ready(timeout=300), "the outer bounds' kernels did not load"
ROWS = 1500
#: decided rows checked against fresh distance queries per case
FRESH = 150


def fresh_apart(w: World, rid: str, margin: float) -> bool:
    """No other body within ``margin`` of the robot at its current state (Bullet distance queries)."""
    body, cid = w.scene.entry(rid).bound.body, w.scene.bullet.cid
    return not any(c[8] <= margin for other in w.scene.table.names if other != body
                   for c in pb.getClosestPoints(body, other, margin, physicsClientId=cid))


def fresh_self_free(w: World, rid: str, bounds: OuterBounds, links: list[int]) -> bool:
    """No link pair the bounds test touches at the robot's current state (Bullet distance queries)."""
    body, cid = w.scene.entry(rid).bound.body, w.scene.bullet.cid
    return not any(c[8] <= 0.0 for a, b in bounds.pairs
                   for c in pb.getClosestPoints(body, body, 0.0, links[a], links[b], physicsClientId=cid))


def ur3_mesh_and_robot(w: World) -> str:
    w.load_robot(str(Path(__file__).resolve().parents[2] / "packages/cli/robots/ur3.urdf"), robot_id="r")
    w.load_robot("kuka_iiwa/model.urdf", robot_id="other", base_position=(0.55, 0.0, 0.0))
    w.set_joint_positions("other", [0.5, 0.8, 0.0, -1.0, 0.0, 0.5, 0.0])
    w.add_obstacle({"name": "part", "shape": {"type": "mesh", "file": str(MODELS / "meshes" / "cube.stl"),
                                              "scale": [0.1, 0.1, 0.1]}, "position": [0.0, -0.3, 0.3]})
    w.add_obstacle({"name": "post", "shape": {"type": "cylinder", "radius": 0.03, "length": 0.5},
                    "position": [-0.25, 0.2, 0.25]})
    return "r"


def among_4_obstacles(urdf: str, name: str, scene: str = "obstacles-4.json") -> Callable[[World], str]:
    """A loader of a pybullet_data robot among the 4 obstacles of the example scene (or another one)."""
    def load(w: World) -> str:
        w.load_robot(urdf, robot_id="r")
        w.load_scene(SCENES / scene)
        return "r"
    load.__name__ = name
    return load


def ur5_tool_table(w: World) -> str:
    r = example_robot("ur5")
    tool = attach_tool(r.urdf, r.package_roots, "tool0", [0, 0, 0.12, 0, 0, 0],
                       shape={"type": "box", "size": [0.05, 0.05, 0.12]})
    w.load_robot(str(tool.urdf), package_roots=tool.package_roots, srdf=r.srdf, robot_id="r",
                 ee_link=tool.tcp_link)
    w.add_obstacle({"name": "table", "shape": {"type": "box", "size": [1.4, 1.4, 0.02]},
                    "position": [0.0, 0.0, -0.06]})
    w.add_obstacle({"name": "ball", "shape": {"type": "sphere", "radius": 0.1}, "position": [0.4, 0.2, 0.3]})
    return "r"


def z1_4(w: World) -> str:
    """The Z1 as published: links of several URDF cylinders (Bullet's hulls) and decomposed meshes."""
    r = example_robot("z1")
    w.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, robot_id="r")
    w.load_scene(SCENES / "obstacles-4.json")
    return "r"


CASES = [among_4_obstacles("kuka_iiwa/model.urdf", "kuka_4"), ur3_mesh_and_robot,
         among_4_obstacles("xarm/xarm6_with_gripper.urdf", "xarm_gripper_4"), ur5_tool_table, z1_4,
         # long links whose spheres reach more than two of the obstacles from one voxel: each obstacle
         # measured by its exact distance
         among_4_obstacles("TwoJointRobot_wo_fixedJoints.urdf", "two_joint_239", "obstacles-239.json")]
#: cases where no row is free of self-contact for sure: the xArm gripper's inner and outer knuckles come
#: within 0.4 mm of each other (Bullet's distance queries), closer than the bounds can tell apart
CLOSE_SELF = {"xarm_gripper_4"}


def _links(w: World, rid: str) -> list[int]:
    """The Bullet link index of each box of the robot's bounds (links with collision shapes, in order)."""
    b = w.scene.entry(rid).bound
    return [ln for ln in range(-1, pb.getNumJoints(b.body, physicsClientId=w.scene.bullet.cid))
            if pb.getCollisionShapeData(b.body, ln, physicsClientId=w.scene.bullet.cid)]


@pytest.mark.parametrize("load", CASES, ids=[c.__name__ for c in CASES])
def test_what_the_bounds_decide_holds_for_fresh_distance_queries(load: Callable[[World], str]) -> None:
    """Rows called apart (with no margin and with a 2 mm margin) and rows called free of self-contact
    are so for Bullet's distance queries; the bounds decide something in every case, and the fresh
    queries catch a known positive (an arm folded into an obstacle's place)."""
    with World() as w:
        rid = load(w)
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(11).uniform(lo, hi, size=(ROWS, len(lo)))
        bounds = w.queries.outer_bounds(rid)
        links = _links(w, rid)
        assert not bounds.empty and [lk.link for lk in bounds.links] == links
        for margin in (0.0, 0.002):
            apart = bounds.apart(qs, margin)
            assert apart.sum() >= ROWS // 20, f"only {apart.sum()} rows apart: the test proves little"
            close = 0
            for i in np.flatnonzero(apart)[:FRESH]:
                w.set_joint_positions(rid, qs[i])
                assert fresh_apart(w, rid, margin), f"row {i} called apart within {margin} m of a body"
            for i in np.flatnonzero(~apart)[:FRESH]:
                w.set_joint_positions(rid, qs[i])
                close += not fresh_apart(w, rid, margin)
            assert close > 0, "the fresh queries found no body near any row not apart"
        free = bounds.self_free(qs)
        if load.__name__ not in CLOSE_SELF:
            assert free.sum() >= ROWS // 20, f"only {free.sum()} rows free of self-contact: proves little"
        for i in np.flatnonzero(free)[:FRESH]:
            w.set_joint_positions(rid, qs[i])
            assert fresh_self_free(w, rid, bounds, links), f"row {i} called free of self-contact"


@pytest.mark.parametrize("load", CASES, ids=[c.__name__ for c in CASES])
def test_labels_with_the_bounds_equal_bullets_labels(load: Callable[[World], str]) -> None:
    """The labels of a batch with the bounds equal those without them (every row to the full world; an
    ASCII STL obstacle is mirrored there as the world converted it: PyBullet crashes on the file itself),
    row for row: Bullet checks other rows in other worlds (the robot alone for a row apart from everything
    else, else the main world) in the two, and its label of a row does not depend on them
    (``client.Recheck``; the xArm's gripper knuckles and the Panda's fingers would flip)."""
    with World() as w:
        rid = load(w)
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(12).uniform(lo, hi, size=(ROWS, len(lo)))
        with_bounds = w.collision_free_batch(rid, qs)
        status = w.queries.outer_bounds(rid).classify(qs, self_always=False, hits=True)
        bullet = w.collision_free_batch(rid, qs, bounds=False)
        assert 0 < bullet.sum() < ROWS
        if load.__name__ not in CLOSE_SELF:
            assert (status == 0).sum() >= ROWS // 20, "the bounds decide too few rows: the test proves little"
        assert not (with_bounds[status == 0] != bullet[status == 0]).any(), "a row free for sure collides"
        assert (status == outerbounds.SURE_HIT).any() and not bullet[status == outerbounds.SURE_HIT].any(), \
            "a sure hit is free for Bullet"
        assert np.array_equal(with_bounds, bullet), np.flatnonzero(with_bounds != bullet)


def test_the_compiled_fk_places_every_link_where_bullet_does() -> None:
    """The kernel's FK of the whole joint tree (couplings applied: the Dobot-like arm's parallelogram)
    puts every link frame where Bullet puts it, on 200 random configurations of each robot."""
    robots = [("kuka_iiwa/model.urdf", (), ()),
              (str(MODELS.parents[2] / "examples" / "robots" / "dobot_like.urdf"), (), ("link_4",))]
    for urdf, rules, level in robots:
        with World() as w:
            w.add_robot(World.read_robot(urdf, couplings=rules, keep_level=level), robot_id="r")
            e = w.scene.entry("r")
            tree, joint_of = joint_tree.joint_tree(list(e.model.joints), list(e.model.controllable),
                                                    list(e.model.couplings), e.model.base_position,
                                                    e.model.base_orientation) or (None, {})
            assert tree is not None
            lo, hi = w.robot_model("r").limits()
            for q in np.random.default_rng(5).uniform(lo, hi, size=(200, len(lo))):
                w.set_joint_positions("r", q)
                p, r = joint_tree.tree_frames(tree, q)
                for ln, name in e.bound.link_names.items():
                    frame = e.bound.bullet.link_frame(e.bound.body, ln)
                    j = joint_of.get(name, -1)  # the root: its frame is the base's
                    assert np.abs(p[j] - frame[0]).max() < 1e-6, (urdf, name)
                    assert np.abs(r[j] - quat_matrix(frame[1])).max() < 1e-6, (urdf, name)


def test_a_parts_spheres_hold_every_point_of_its_hull() -> None:
    """The spheres fitted to a convex part hold its hull: random convex combinations of its vertices lie
    inside one of them, for long, flat and round parts."""
    rng = np.random.default_rng(8)
    parts = [rng.normal(size=(40, 3)) * scale for scale in ([0.3, 0.05, 0.04], [0.1, 0.1, 0.005], [0.05] * 3)]
    for points in parts:
        spheres = robot_shapes.part_spheres(points, 0.0)
        weights = rng.dirichlet(np.ones(len(points)) * 0.3, size=5000)
        inside = weights @ points
        centres = np.array([c for c, _ in spheres])
        radii = np.array([r for _, r in spheres])
        gap = np.linalg.norm(inside[:, None, :] - centres[None], axis=2) - radii[None]
        assert (gap.min(axis=1) <= 1e-9).all(), f"{len(spheres)} spheres leave hull points out"


def test_stale_bounds_are_built_again_only_once_bullet_paid_for_them() -> None:
    """Path checks in a world that keeps changing: after an obstacle moved, short checks run on Bullet
    alone (none decided by the bounds) until their states would have paid for a build; then the bounds
    are built for the world as it is and decide states again."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="k")
        w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]},
                        "position": [0.6, 0.0, 0.3]})
        entry = w.scene.entry("k")
        cache = w.scene.bounds
        qs = np.zeros((10, 7)) + np.linspace(0.0, 0.2, 10)[:, None]  # far from the box
        assert cache.sure_free(w.scene, "k", entry, qs, 0.002)[0].all()  # built at first use
        w.move_obstacle("box", [0.6, 0.1, 0.3])
        per_build = cache._rent["k"]
        asked = 0
        while asked + len(qs) < per_build:
            assert not cache.sure_free(w.scene, "k", entry, qs, 0.002)[0].any()  # stale: Bullet's
            asked += len(qs)
        assert cache.sure_free(w.scene, "k", entry, qs, 0.002)[0].all()  # paid for: built anew
        assert cache._bounds["k"][0] == w.scene.others_stamp("k")


def test_rows_ahead_are_tested_until_the_rows_not_known_free_asked_for() -> None:
    """``free_ahead`` on a KUKA sweeping through a box: with no limit every row is tested and the verdicts
    are ``classify``'s; with a limit of k the rows are tested up to the k-th not known free, the same
    verdicts on those."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="k")
        w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]},
                        "position": [0.6, 0.0, 0.3]})
        bounds = w.scene.bounds.get(w.scene, "k")
        qs = np.zeros((400, 7))
        qs[:, 0] = np.linspace(-2.0, 2.0, 400)
        qs[:, 1] = 1.4
        want = bounds.classify(qs, 0.002) == 0
        unsure = np.flatnonzero(~want)
        assert 10 < len(unsure) < 300  # both verdicts occur
        free, tested = bounds.free_ahead(qs, 0.002, 0)
        assert tested == len(qs) and (free == want).all()
        for k in (1, 2, 7):
            free, tested = bounds.free_ahead(qs, 0.002, k)
            assert tested == unsure[k - 1] + 1
            assert (free[:tested] == want[:tested]).all()


def test_the_kernel_called_without_numbas_dispatch_gives_the_dispatchers_verdicts() -> None:
    """After its first call an instance calls the kernel's machine code for its argument types directly
    (``OuterBounds._call``): found here (not the dispatcher), with the verdicts and tested counts the
    dispatcher gives for the same rows, margins and limits."""
    from robwot_sim.sim.bounds_kernel import classify

    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="k")
        w.add_obstacle({"name": "box", "shape": {"type": "box", "size": [0.2, 0.2, 0.2]},
                        "position": [0.6, 0.0, 0.3]})
        bounds = w.scene.bounds.get(w.scene, "k")
        lo, hi = w.robot_model("k").limits()
        qs = np.random.default_rng(3).uniform(lo, hi, (300, 7))
        bounds.classify(qs[:1])
        assert bounds._compiled is not None and bounds._compiled is not classify
        for margin, hits, stop in ((0.0, False, 0), (0.002, False, 5), (0.0, True, 0), (0.02, True, 1)):
            got, tested = bounds._classify(qs, margin, True, hits, stop)
            robot = bounds.robot
            assert robot is not None
            want = np.full(len(qs), 3, dtype=np.int8)
            count = classify(qs, robot.tree, robot.shapes, robot.tables, bounds.bodies, bounds.grid,
                             bounds.zone, margin, GROW, HULL_GAP, TOLERANCE, True, hits, DEPTH, stop, want)
            assert tested == count and (got == want).all()
        assert len(set(bounds.classify(qs, 0.002))) > 1  # both verdicts occur


def _vertices(bounds: OuterBounds, link: int, p: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The vertices the self test uses of bounds link ``link`` (its parts' few and their whole hulls'), in
    the world (frames ``p``, ``r``)."""
    s = bounds.robot.shapes if bounds.robot else None
    assert s is not None
    f = int(s.joint[link]) if s.joint[link] >= 0 else len(p) - 1
    first, end = s.part_first[link], s.part_end[link] - 1
    v = np.concatenate([s.verts[s.vert_first[first]:s.vert_end[end]],
                        s.hull[s.hull_first[first]:s.hull_end[end]]])
    return np.asarray(p[f] + v @ r[f].T)


@pytest.mark.parametrize("robot", ["kuka_iiwa/model.urdf", "xarm/xarm6_with_gripper.urdf", "dobot_like",
                                   "franka_panda/panda.urdf"])
def test_a_pair_tables_rates_bound_how_fast_its_links_move(robot: str) -> None:
    """Each self pair's table holds the coordinates its links' relative pose depends on and rates no
    hull vertex exceeds: moving those coordinates from random configurations moves each link's vertices,
    seen from the frame the two links' joint chains share, by no more in all than the rates times the
    moves (mimic joints, the Dobot-like arm's couplings and the Panda's prismatic fingers included), and
    moving only the other coordinates leaves the one link still as seen from the other."""
    with World() as w:
        if robot == "dobot_like":
            urdf = str(MODELS.parents[2] / "examples" / "robots" / "dobot_like.urdf")
            w.add_robot(World.read_robot(urdf, keep_level=("link_4",)), robot_id="r")
        else:
            w.load_robot(robot, robot_id="r")
        bounds = w.queries.outer_bounds("r")
        assert bounds.robot is not None
        tree, tab, s = bounds.robot.tree, bounds.robot.tables, bounds.robot.shapes
        assert (tab.dims >= 0).any(), "no pair has a table: the test proves nothing"
        if robot.startswith("franka"):
            sliding = {int(c) for j in np.flatnonzero(tree.kind == 2)
                       for c in np.flatnonzero(tree.coupling[j])}
            assert any(sliding & set(tab.coord[k, :tab.dims[k]].tolist())
                       for k in np.flatnonzero(tab.dims >= 0))
        lo, hi = w.robot_model("r").limits()
        rng = np.random.default_rng(3)
        for k in np.flatnonzero(tab.dims >= 0):
            coords = tab.coord[k, :tab.dims[k]]
            la, lb = s.pair_a[k], s.pair_b[k]
            chains = [joint_tree.ancestors(tree, int(s.joint[ln])) for ln in (la, lb)]
            shared = [j for j in chains[0] if j in chains[1]]
            top = shared[0] if shared else len(tree.parent)  # the root's frame: the last
            for q in rng.uniform(lo, hi, size=(40, len(lo))):
                moved, other = q.copy(), q.copy()
                moved[coords] = rng.uniform(lo[coords], hi[coords])
                rest = np.setdiff1d(np.arange(len(lo)), coords)
                other[rest] = rng.uniform(lo[rest], hi[rest])
                seen = []
                for x in (q, moved, other):
                    p, r = joint_tree.tree_frames(tree, x)
                    seen.append([(_vertices(bounds, ln, p, r) - p[top]) @ r[top] for ln in (la, lb)])
                bound = float(np.dot(tab.rate[k, :tab.dims[k]], np.abs(moved[coords] - q[coords])))
                moves = sum(np.linalg.norm(seen[1][m] - seen[0][m], axis=1).max() for m in range(2))
                assert moves <= bound + 1e-9, (k, q)
                p, r = joint_tree.tree_frames(tree, other)
                f = int(s.joint[lb]) if s.joint[lb] >= 0 else len(p) - 1
                p0, r0 = joint_tree.tree_frames(tree, q)
                f0 = (_vertices(bounds, la, p0, r0) - p0[f]) @ r0[f]
                assert np.abs((_vertices(bounds, la, p, r) - p[f]) @ r[f] - f0).max() < 1e-9, (k, q)


def test_pairs_a_table_calls_apart_are_apart_for_fresh_distance_queries() -> None:
    """Configurations a self pair's table alone calls apart are more than the hull gap apart for Bullet's
    distance queries between that pair's links, with its cells filled by a batch as rows fall in them and
    with all of them filled at once (a servient's warm-up); the tables decide most pairs of the KUKA arm."""
    from robwot_sim.sim.pair_kernel import table_apart

    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="r")
        bounds = w.queries.outer_bounds("r")
        assert bounds.robot is not None
        tab, s = bounds.robot.tables, bounds.robot.shapes
        lo, hi = w.robot_model("r").limits()
        qs = np.random.default_rng(4).uniform(lo, hi, size=(3000, len(lo)))
        bounds.classify(qs[100:])
        filled = tab.gap.copy()
        bounds.fill_tables()
        assert not np.isnan(tab.gap).any()
        assert np.array_equal(tab.gap[~np.isnan(filled)], filled[~np.isnan(filled)])  # a cell is written once
        body, cid = w.scene.entry("r").bound.body, w.scene.bullet.cid
        links = _links(w, "r")
        decided = 0
        for q in qs[:100]:
            w.set_joint_positions("r", q)
            for k in np.flatnonzero(tab.dims >= 0):
                if table_apart(tab, int(k), q, outerbounds.HULL_GAP + outerbounds.TOLERANCE) != 1:
                    continue
                decided += 1
                near = pb.getClosestPoints(body, body, outerbounds.HULL_GAP, links[s.pair_a[k]],
                                           links[s.pair_b[k]], physicsClientId=cid)
                assert not near, (k, q, [c[8] for c in near])
        assert decided >= 0.8 * 100 * (tab.dims >= 0).sum(), decided


def test_kernel_caches_are_emptied_when_any_kernel_source_changed(tmp_path: Path) -> None:
    """numba keys a kernel's cache by its own file; a kernel holds copies of the kernels it calls from the
    other files, so every cache is emptied unless the stamp names all five sources as they are."""
    import hashlib

    from robwot_sim.sim import bounds_kernel, gjk_kernel, hit_kernel, pair_kernel, sphere_kernel

    kernels.kernels_ready(timeout=kernels.KERNELS_WAIT)
    caches, stamp, sources = kernels._kernel_caches()
    assert len(caches) >= 11  # every kernel of the five files
    modules = (sphere_kernel, gjk_kernel, hit_kernel, pair_kernel, bounds_kernel)
    files = [Path(str(m.__file__)) for m in modules]
    assert sources == hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()
    assert stamp.read_text() == sources  # written once the kernels loaded

    class Cache:
        flushed = 0

        def flush(self) -> None:
            Cache.flushed += 1

    fakes: list[object] = [Cache(), Cache()]
    mine = tmp_path / "stamp"
    mine.write_text(sources)
    kernels.flush_stale(fakes, mine, sources)
    assert Cache.flushed == 0
    for other in ("0" * 64, ""):
        mine.write_text(other)
        kernels.flush_stale(fakes, mine, sources)
    mine.unlink()
    kernels.flush_stale(fakes, mine, sources)
    assert Cache.flushed == 6


BALL_ARM = """<?xml version="1.0"?>
<robot name="ball_arm">
  <link name="base"/>
  <link name="ball">
    <inertial><mass value="0.1"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
    <collision><origin xyz="0.3 0 0"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="turn" type="revolute">
    <parent link="base"/><child link="ball"/><axis xyz="0 0 1"/>
    <limit lower="-3.14" upper="3.14" velocity="1" effort="1"/>
  </joint>
</robot>
"""


def test_a_spheres_box_is_no_point_of_it_for_sure_hits(tmp_path: Path) -> None:
    """A link's sphere is held by its box's corners, which are no points of the sphere: a corner deep in an
    obstacle the sphere itself keeps 2 cm from is no sure hit (Bullet: free), so such a part's corners are
    not asked (``own``), while a sphere sunk into the obstacle stays one."""
    urdf = tmp_path / "ball_arm.urdf"
    urdf.write_text(BALL_ARM)
    diagonal = np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
    # a box whose face, normal to the diagonal, lies 0.07 m from the ball's centre: the ball (0.05 m) is
    # 2 cm off it, its box's corner (0.087 m out) 17 mm inside
    turn = np.cross([0.0, 0.0, 1.0], diagonal)
    angle = float(np.arccos(diagonal[2]))
    quat = [*(np.sin(angle / 2) * turn / np.linalg.norm(turn)), float(np.cos(angle / 2))]
    centre = np.array([0.3, 0.0, 0.0]) + diagonal * (0.07 + 0.1)
    with World() as w:
        rid = w.load_robot(str(urdf), robot_id="r").id
        w.add_obstacle({"name": "slab", "shape": {"type": "box", "size": [0.6, 0.6, 0.2]},
                        "position": centre.tolist(), "orientation": quat})
        assert w.collision_free_batch(rid, np.zeros((1, 1)), bounds=False)[0]
        status = w.queries.outer_bounds(rid).classify(np.zeros((1, 1)), self_always=False, hits=True)
        assert status[0] != outerbounds.SURE_HIT
        sunk = np.array([[0.0]])
        w.remove_obstacle("slab")
        w.add_obstacle({"name": "slab", "shape": {"type": "box", "size": [0.6, 0.6, 0.2]},
                        "position": (centre - diagonal * 0.1).tolist(), "orientation": quat})
        assert not w.collision_free_batch(rid, sunk, bounds=False)[0]
        status = w.queries.outer_bounds(rid).classify(sunk, self_always=False, hits=True)
        assert status[0] == outerbounds.SURE_HIT


def test_a_corner_deep_in_the_other_links_hull_is_a_sure_self_hit() -> None:
    """The UR5 alone, seeded random rows: a self pair whose one link has a corner (a point of it) deeper than
    ``DEPTH`` inside a hull of the other (``hit_kernel.sunk_pair``) touches for Bullet, on every such row,
    and there are such rows (its links come close at many)."""
    with World() as w:
        r = example_robot("ur5")
        rid = w.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, robot_id="r").id
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(39).uniform(lo, hi, size=(ROWS, len(lo)))
        free = w.collision_free_batch(rid, qs, bounds=False)
        bounds = w.queries.outer_bounds(rid)
        assert bounds.robot is not None
        shapes, tree = bounds.robot.shapes, bounds.robot.tree
        scratch = np.empty(3), np.empty(3)
        proven = [i for i, q in enumerate(qs)
                  if any(sunk_pair(shapes, k, len(tree.parent), *joint_tree.tree_frames(tree, q), DEPTH,
                                   outerbounds.TOLERANCE, *scratch) for k in range(len(shapes.pair_a)))]
        assert len(proven) >= ROWS // 50, "too few rows in self-contact proven: the test shows little"
        assert not free[proven].any(), "a row proven in self-contact is free for Bullet"


def test_a_link_deep_in_the_fixed_base_is_a_sure_self_hit() -> None:
    """The bundled UR3 alone (URDF cylinders; its fixed base has no mass for Bullet, which still reports the
    base's contacts with the links that have): rows where only pairs with the base touch, by more than 5 mm
    for fresh distance queries, are colliding for Bullet and most of them are sure hits."""
    with World() as w:
        ur3 = MODELS.parents[2] / "packages" / "cli" / "robots" / "ur3.urdf"
        rid = w.load_robot(str(ur3), robot_id="r").id
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(26).uniform(lo, hi, size=(ROWS, len(lo)))
        free = w.collision_free_batch(rid, qs, bounds=False)
        bounds = w.queries.outer_bounds(rid)
        hits = bounds.classify(qs, self_always=False, hits=True) == outerbounds.SURE_HIT
        assert not free[hits].any(), "a sure hit is free for Bullet"
        body, cid = w.scene.entry(rid).bound.body, w.scene.bullet.cid
        links = _links(w, rid)
        base_only = []
        for i, q in enumerate(qs[:600]):
            w.set_joint_positions(rid, q)
            touching = {(a, b): min(c[8] for c in near) for a, b in bounds.pairs
                        if (near := pb.getClosestPoints(body, body, 0.0, links[a], links[b],
                                                        physicsClientId=cid))}
            if touching and all(links[a] < 0 for a, _ in touching) and min(touching.values()) < -0.005:
                base_only.append(i)
        assert len(base_only) >= 10, "too few rows touching the base alone: the test shows little"
        assert not free[base_only].any()
        assert hits[base_only].mean() >= 0.5, hits[base_only].mean()


@njit(cache=False)
def _rows_with_a_body_inside(qs: np.ndarray, tree: joint_tree.Tree, s: robot_shapes.Shapes,
                             b: outerbounds.Bodies, depth: float) -> np.ndarray:
    """Per row: whether a point of a primitive obstacle lies more than ``depth`` inside a moving part's hull
    (``hit_kernel._body_inside``, every own part against every exact body)."""
    n = tree.parent.shape[0]
    P, R, c = np.empty((n + 1, 3)), np.empty((n + 1, 3, 3)), np.empty(3)
    out = np.zeros(qs.shape[0], dtype=np.bool_)
    for i in range(qs.shape[0]):
        frames(tree, qs[i], P, R)
        for ln in range(s.joint.shape[0]):
            f = s.joint[ln] if s.joint[ln] >= 0 else n
            for p in range(s.part_first[ln], s.part_end[ln]):
                place(P, R, f, s.box_c[p], c)
                for k in range(b.kind.shape[0]):
                    reach = s.box_r[p] + np.sqrt((b.size[k] ** 2).sum())
                    far = ((b.centre[k] - c) ** 2).sum() > reach**2
                    if far or not (s.moving[ln] and s.own[p] and b.exact[k]):
                        continue
                    out[i] |= _body_inside(s, b, k, p, f, P, R, depth)
    return out


def test_an_obstacles_point_deep_in_a_links_hull_is_a_sure_hit() -> None:
    """The KUKA among the 239 obstacles, seeded random rows: where a point of an obstacle (a box's corner,
    a centre) lies more than ``DEPTH`` inside a hull of a moving link (``hit_kernel._body_inside``), the
    row touches for Bullet, and there are such rows."""
    with World() as w:
        rid = w.load_robot("kuka_iiwa/model.urdf", robot_id="r").id
        w.load_scene(SCENES / "obstacles-239.json")
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(39).uniform(lo, hi, size=(ROWS, len(lo)))
        free = w.collision_free_batch(rid, qs, bounds=False)
        bounds = w.queries.outer_bounds(rid)
        assert bounds.robot is not None and bounds.bodies is not None
        proven = _rows_with_a_body_inside(qs, bounds.robot.tree, bounds.robot.shapes, bounds.bodies,
                                          DEPTH + outerbounds.TOLERANCE)
        assert proven.sum() >= ROWS // 50, "too few rows proven: the test shows little"
        assert not free[proven].any(), "a row with an obstacle's point inside a link is free for Bullet"


def test_the_kernels_stamp_is_never_read_half_written(tmp_path: Path) -> None:
    """Every process that loads the kernels writes their stamp while others read it (``flush_stale``): a
    stamp read half-written emptied every cache in a CI run and made its backends compile the kernels again
    for minutes. It is left alone when it already holds the sources (no write at all), else replaced whole
    by a renamed file (a new inode), leaving no temporary file."""
    stamp = tmp_path / "robwot-kernels.sha256"
    kernels.write_stamp(stamp, "a" * 64)
    assert stamp.read_text() == "a" * 64
    first = stamp.stat()
    kernels.write_stamp(stamp, "a" * 64)
    assert stamp.stat().st_mtime_ns == first.st_mtime_ns and stamp.stat().st_ino == first.st_ino
    kernels.write_stamp(stamp, "b" * 64)
    assert stamp.read_text() == "b" * 64 and stamp.stat().st_ino != first.st_ino
    assert [p.name for p in tmp_path.iterdir()] == [stamp.name]


def test_a_batch_builds_a_mirror_only_for_rows_that_need_it() -> None:
    """A KUKA among 239 boxes: the bounds find no row apart from every other body but not free, so a batch
    builds no mirror of the robot alone (a labelling worker built one at its start, a tenth of it, and
    never used it), nor of the scene merging its obstacles: the rows Bullet must check lie near obstacles,
    where it pays nothing, and the main world checks them, with the labels of Bullet alone."""
    with World() as w:
        rid = w.load_robot("kuka_iiwa/model.urdf", robot_id="k").id
        w.load_scene(str(SCENES / "obstacles-239.json"))
        lo, hi = w.robot_model(rid).limits()
        qs = np.random.default_rng(5).uniform(lo, hi, size=(ROWS, len(lo)))
        status = w.queries.outer_bounds(rid).classify(qs, self_always=False, hits=True)
        assert not (status == 2).any() and (status == 3).any()
        labels = w.collision_free_batch(rid, qs)
        assert rid not in w.queries._alone and w.queries._fast is None
        assert np.array_equal(labels, w.collision_free_batch(rid, qs, bounds=False))
