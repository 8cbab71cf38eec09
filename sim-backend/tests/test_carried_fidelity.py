"""A carried object against the independent exact-mesh reference (Pinocchio + Coal,
``robwot_bench.reference``) with the scene's boxes added to it: the Panda as published for ROS
(example-robot-data, with its SRDF, the TCP between the fingertips) grips a 5 cm cube (``World.grippers``),
which becomes a link of the twin's robot; the reference gets the same cube fixed to the TCP frame where the
twin holds it (the held object's pose from ``World.list``, the TCP's from ``World.fk``), checked against the
obstacles and every link but the hand's, as the twin does. The reference is first shown to catch the cube
alone 1 cm inside the table or a box (the robot itself clear) and to call it free 1 cm above. Then random
pose targets among the obstacles are planned by the backend's planner while holding the cube, and every
state each accepted move passes (its timed states, subdivided so no point of the arm or the cube moves more
than 4 mm between two checked ones) is checked by the reference: none may touch an obstacle or the robot
itself; refused moves whose straight path the reference finds free are counted. Last, the twin's labels
of configurations around IK solutions putting the cube at the obstacles' faces are compared with the
reference's: no false "free". ``pytest -s`` prints the figures."""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
import pybullet as pb
import pytest

from robwot_bench.reference import ExactReference, example_robot
from robwot_sim.errors import Unreachable
from robwot_sim.sim.planner import Goal, Timing, plan
from robwot_sim.sim.world import World

TCP = "panda_hand_tcp"  # example-robot-data's TCP frame, 10.34 cm below the hand: between the fingertips
#: the links the gripper is mounted on and below it (the twin's ``gripper.hand_links``): never checked
#: against the cube it holds
HAND = ("panda_hand", "panda_leftfinger", "panda_rightfinger", TCP)
DOWN = (1.0, 0.0, 0.0, 0.0)  # the hand's z axis pointing down
#: the robot's base stands 2 cm above the table top (the twin checks the base link against the table, the
#: reference does not) and the table on the floor (objects are never placed below it). World frame (the
#: twin's); the reference's is the base's
BASE = np.array([0.0, 0.0, 0.02])
TABLE_TOP = 0.0
CUBE = 0.05
BOXES = {"table": ([1.6, 1.6, 0.04], [0.2, 0.0, TABLE_TOP - 0.02]),
         "post": ([0.15, 0.15, 0.30], [0.45, -0.35, TABLE_TOP + 0.15]),
         "shelf": ([0.10, 0.50, 0.08], [0.35, 0.30, 0.45]),
         "wall": ([0.06, 0.30, 0.16], [0.78, 0.05, TABLE_TOP + 0.08])}
CUBE_AT = [0.55, 0.0, TABLE_TOP + CUBE / 2]
LIFTED = [0.55, 0.0, 0.30]
#: metres a point of link j's subtree may be from joint j's axis, at most: the chain's lengths beyond the
#: joint (Panda: 0.316, 2 x 0.0825, 0.384, 0.088, 0.107, the TCP's 0.1034), the cube's half diagonal (0.043)
#: and 0.1 m for the links' own bulk; the finger joint is pinned. Bounds how far a point moves for a step
LEVER = np.array([1.3, 1.3, 1.3, 0.9, 0.45, 0.45, 0.25, 0.0])
#: metres any point may move between two states the reference checks (a contact the reference would find
#: between two of them is under 2 mm deep; the twin keeps 2 mm off obstacles)
STEP = 0.004
MOVES = 24
SAMPLES = 3000
#: configurations labelled per IK solution at an obstacle, and how far (rad) each joint is moved off it
PER_SOLUTION = 30
PERTURB = 0.05


@dataclass
class Cell:
    world: World
    robot: str
    lifted: np.ndarray
    #: the cube in the TCP frame (position, quaternion xyzw), as the twin holds it
    offset: tuple[list[float], list[float]]
    #: the reference without the cube and with it
    bare: ExactReference
    carried: ExactReference


def _quat(roll: float, pitch: float, yaw: float) -> list[float]:
    return list(pb.getQuaternionFromEuler([roll, pitch, yaw]))


@pytest.fixture(scope="module")
def cell() -> Iterator[Cell]:
    r = example_robot("panda")
    with World() as world:
        model = world.load_robot(str(r.urdf), package_roots=r.package_roots, srdf=r.srdf, ee_link=TCP,
                                 base_position=BASE.tolist())
        rid = model.id
        for name, (size, pos) in BOXES.items():
            world.add_obstacle({"name": name, "shape": {"type": "box", "size": size}, "position": pos})
        world.add_object({"name": "cube", "shape": {"type": "box", "size": [CUBE] * 3}, "position": CUBE_AT})
        world.grippers.configure(rid, "fingers")
        world.set_joint_positions(rid, world.ik(rid, CUBE_AT, DOWN, collision_free=False).positions)
        assert world.grippers.close(rid)["holding"] == "cube"
        lifted = np.array(world.ik(rid, LIFTED, DOWN).positions)
        world.set_joint_positions(rid, lifted)
        assert world.check_collision(rid).collision_free
        # the cube's pose in the TCP frame, from what the twin tells: offset = inv(tcp) * cube
        (held,) = [o for o in world.list()["objects"] if o.get("heldBy") == rid]
        assert held["shape"]["size"] == [CUBE] * 3
        tcp = world.fk(rid)
        inv_p, inv_q = pb.invertTransform(tcp.position, tcp.quat_xyzw)
        p, q = pb.multiplyTransforms(inv_p, inv_q, held["position"], held["orientation"])
        offset = (list(p), list(q))
        obstacles = [(size, (np.asarray(pos) - BASE).tolist(), [0.0, 0.0, 0.0, 1.0])
                     for size, pos in BOXES.values()]
        bare = ExactReference(r.urdf, r.package_roots, model.controllable, r.srdf, obstacles, mimic=True)
        carried = ExactReference(r.urdf, r.package_roots, model.controllable, r.srdf, obstacles, mimic=True)
        carried.attach_box(TCP, [CUBE] * 3, *offset, ignore=HAND)
        assert bare.collision_free(lifted[None, :])[0] and carried.collision_free(lifted[None, :])[0]
        yield Cell(world, rid, lifted, offset, bare, carried)


def _dense(states: np.ndarray) -> np.ndarray:
    """The states with enough linear subdivisions between neighbours that no point moves more than STEP."""
    out = [states[:1]]
    for a, b in itertools.pairwise(states):
        n = max(1, math.ceil(float(np.abs(b - a) @ LEVER) / STEP))
        out.append(a + np.arange(1, n + 1)[:, None] / n * (b - a))
    return np.concatenate(out)


def _cube_clearance(cell: Cell, qs: np.ndarray) -> float:
    """The smallest signed distance (m) between the cube and an obstacle over the rows of ``qs``, by the
    reference's kinematics and Coal (negative: they overlap)."""
    import coal
    import pinocchio as pin

    ref = cell.carried
    data = ref.model.createData()
    fid = ref.model.getFrameId(TCP)
    x, y, z, w = cell.offset[1]
    offset = pin.SE3(pin.Quaternion(w, x, y, z).matrix(), np.asarray(cell.offset[0]))
    cube = coal.Box(CUBE, CUBE, CUBE)
    boxes = [(coal.Box(*size), coal.Transform3s(np.eye(3), np.asarray(pos) - BASE))
             for size, pos in BOXES.values()]
    out = math.inf
    for q in qs:
        pin.framesForwardKinematics(ref.model, data, ref.configuration(q))
        at = data.oMf[fid] * offset
        pose = coal.Transform3s(at.rotation, at.translation)
        for box, where in boxes:
            result = coal.DistanceResult()
            out = min(out, coal.distance(cube, pose, box, where, coal.DistanceRequest(), result))
    return out


def _gap(point: np.ndarray, size: list[float], centre: list[float]) -> float:
    """A point's distance (m) to an axis-aligned box (0 inside)."""
    return float(np.linalg.norm(np.maximum(np.abs(point - np.asarray(centre)) - np.asarray(size) / 2, 0.0)))


def test_the_reference_and_the_twin_catch_the_carried_cube_alone(cell: Cell) -> None:
    """The cube 1 cm into the table or the post, the fingertips above it: colliding for both, the robot
    alone free for the reference; 1 cm above it: free for both."""
    w, rid = cell.world, cell.robot
    w.set_joint_positions(rid, cell.lifted)
    for name, xy, top in (("table", [0.6, -0.1], TABLE_TOP), ("post", [0.45, -0.35], TABLE_TOP + 0.30)):
        into = np.array(w.ik(rid, [*xy, top + CUBE / 2 - 0.01], DOWN, collision_free=False).positions)
        clear = np.array(w.ik(rid, [*xy, top + CUBE / 2 + 0.01], DOWN, collision_free=False).positions)
        qs = np.array([into, clear])
        assert cell.bare.collision_free(qs).tolist() == [True, True], f"the robot itself touches the {name}"
        assert cell.carried.collision_free(qs).tolist() == [False, True], f"the cube in the {name}"
        # the reference's cube is where the twin's is: 1 cm into the surface, then 1 cm off it
        assert _cube_clearance(cell, into[None, :]) == pytest.approx(-0.01, abs=1e-3)
        assert _cube_clearance(cell, clear[None, :]) == pytest.approx(0.01, abs=1e-3)
        assert w.collision_free_batch(rid, qs).tolist() == [False, True]
        contacts = w.check_collision(rid, into).contacts
        assert {(c.a.link, c.b.body) for c in contacts} == {("cube", name)}
        assert max(c.depth for c in contacts) == pytest.approx(0.01, abs=2e-3)


def test_every_state_of_every_move_holding_the_cube_is_free_for_the_exact_reference(cell: Cell) -> None:
    w, rid = cell.world, cell.robot
    w.set_joint_positions(rid, cell.lifted)
    rng = np.random.default_rng(11)
    moves: list[np.ndarray] = []
    refused = refused_free = refused_unjudged = detours = 0
    while len(moves) + refused < MOVES:
        position = rng.uniform([0.2, -0.55, TABLE_TOP + 0.04], [0.75, 0.55, 0.6])
        # the cube's centre 5 cm or more off every obstacle (never inside one)
        if min(_gap(position, size, pos) for size, pos in BOXES.values()) < CUBE:
            continue
        orientation = _quat(math.pi + rng.uniform(-0.4, 0.4), rng.uniform(-0.4, 0.4), rng.uniform(-1.5, 1.5))
        start = np.array(w.get_joint_positions(rid))
        goal = Goal("ptp", position=tuple(position), orientation=tuple(orientation))
        verdict = plan(w, rid, goal, Timing())
        if verdict.valid:
            assert verdict.path is not None and verdict.target is not None
            moves.append(verdict.path.rows())
            detours += bool(verdict.via)
            w.set_joint_positions(rid, verdict.target)
            continue
        refused += 1
        target = verdict.target
        if target is None:
            try:
                target = w.ik(rid, position.tolist(), orientation, collision_free=False).positions
            except Unreachable:
                refused_unjudged += 1
                continue
        refused_free += bool(cell.carried.collision_free(_dense(np.array([start, target]))).all())
    assert len(moves) >= MOVES // 2, f"{len(moves)} of {MOVES} moves accepted: the test proves little"
    states = np.concatenate([_dense(m) for m in moves])
    free = cell.carried.collision_free(states)
    near = _cube_clearance(cell, np.concatenate(moves))
    print(f"\ncarried cube, {len(moves)} moves accepted ({detours} detours), "
          f"{sum(len(m) for m in moves)} timed states, {len(states)} checked: {int(np.sum(~free))} touching "
          f"for the reference (the cube {1e3 * near:.1f} mm from an obstacle at the closest); {refused} "
          f"refused, {refused_free} of them with a straight path the reference finds free, "
          f"{refused_unjudged} without an IK solution")
    assert free.all(), f"the exact reference finds contact at {states[~free][0].tolist()}"


def _near_configurations(cell: Cell, rng: np.random.Generator) -> np.ndarray:
    """SAMPLES joint vectors around IK solutions that put the cube on the table's top or an obstacle's top
    or side, from 1 cm into it to 3 cm off it (the hand down, tilted up to 0.3 rad): the solutions
    perturbed by up to PERTURB rad per joint, the fingers kept."""
    w, rid = cell.world, cell.robot
    lo, hi = (np.asarray(v, dtype=np.float64) for v in w.robot_model(rid).limits())
    out: list[np.ndarray] = []
    names = list(BOXES)
    while len(out) * PER_SOLUTION < SAMPLES:
        size, centre = (np.asarray(v) for v in BOXES[names[int(rng.integers(len(names)))]])
        point = centre + rng.uniform(-0.5, 0.5, 3) * size
        axis = 2 if size[0] > 1.0 else int(rng.integers(3))  # the table: its top only
        sign = 1.0 if axis == 2 else float(rng.choice([-1.0, 1.0]))
        point[axis] = centre[axis] + sign * (size[axis] / 2 + CUBE / 2 + rng.uniform(-0.01, 0.03))
        # at a side, the fingers (the hand's y axis; world y at yaw 0) along the face, not between it and
        # the cube
        yaw = rng.uniform(-math.pi, math.pi) if axis == 2 else math.pi / 2 * axis + rng.uniform(-0.3, 0.3)
        turn = _quat(math.pi + rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), yaw)
        try:
            q = np.asarray(w.ik(rid, point.tolist(), turn, collision_free=False).positions)
        except Unreachable:
            continue
        around = q + rng.uniform(-PERTURB, PERTURB, size=(PER_SOLUTION, len(q)))
        around[:, -1] = q[-1]
        out.append(np.clip(around, lo, hi))
    return np.concatenate(out)[:SAMPLES]


def test_labels_with_the_cube_near_the_obstacles_agree_with_the_exact_reference(cell: Cell) -> None:
    w, rid = cell.world, cell.robot
    w.set_joint_positions(rid, cell.lifted)
    qs = _near_configurations(cell, np.random.default_rng(13))
    ours = w.collision_free_batch(rid, qs)
    truth = cell.carried.collision_free(qs)
    robot_alone = truth.copy()
    robot_alone[~truth] = cell.bare.collision_free(qs[~truth])
    false_free = int(np.sum(ours & ~truth))
    false_colliding = int(np.sum(~ours & truth))
    cube_alone = int(np.sum(robot_alone & ~truth))
    print(f"\ncarried cube, {len(qs)} configurations with the cube at the obstacles: reference free "
          f"{int(truth.sum())}, colliding {int((~truth).sum())} ({cube_alone} by the cube alone); twin false "
          f"\"free\" {false_free}, false \"colliding\" {false_colliding} "
          f"({100 * false_colliding / max(1, int(truth.sum())):.1f} % of the reference-free)")
    assert false_free == 0, f"the twin calls {qs[ours & ~truth][0].tolist()} free"
    assert cube_alone >= SAMPLES // 10 and truth.sum() >= SAMPLES // 4, "the samples prove little"
