"""Parallel-linkage arms loaded with couplings, against an independent reference: Pinocchio's FK and
Pinocchio + Coal's exact collision checks of the same URDF, with every follower set by the linkage's own
hand-written formula (never by our coupling code)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

from robwot_bench.reference import ExactReference
from robwot_sim.errors import InvalidParams, OutOfLimits
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import generate_workspace

ROBOTS = Path(__file__).resolve().parents[2] / "examples" / "robots"
DOBOT = ROBOTS / "dobot_like.urdf"
UARM = ROBOTS / "uarm_like.urdf"
UARM_RULES = ("bar_joint=joint_2+joint_3", "plate_joint=-joint_2")
Formula = Callable[[dict[str, np.ndarray]], dict[str, np.ndarray]]


def dobot_followers(q: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {"joint_4": -q["joint_2"] - q["joint_3"]}


def uarm_followers(q: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return {"end_joint": -q["joint_2"] - q["joint_3"], "bar_joint": q["joint_2"] + q["joint_3"],
            "plate_joint": -q["joint_2"]}


CASES = [(DOBOT, (), ("link_4",), "link_4", dobot_followers),
         (UARM, UARM_RULES, ("end",), "end", uarm_followers)]


@pytest.fixture
def world() -> Iterator[World]:
    with World() as w:
        yield w


def _load(w: World, urdf: Path, rules: tuple[str, ...], level: tuple[str, ...], rid: str = "arm") -> None:
    files = World.read_robot(str(urdf), couplings=rules, keep_level=level)
    w.add_robot(files, robot_id=rid)


def _full(names: tuple[str, ...], qs: np.ndarray, formula: Formula) -> tuple[list[str], np.ndarray]:
    """Every movable joint's values: the leaders as given, the followers by the linkage's formula."""
    by_name = {n: qs[:, i] for i, n in enumerate(names)}
    followers = formula(by_name)
    return [*names, *followers], np.column_stack([qs, *followers.values()])


def _draw(w: World, n: int, seed: int) -> np.ndarray:
    lo, hi = w.robot_model("arm").limits()
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, len(lo)))


def _pin_frames(urdf: Path, joints: list[str], full: np.ndarray, link: str) -> tuple[np.ndarray, np.ndarray]:
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    frame = model.getFrameId(link)
    slots = [model.joints[model.getJointId(n)].idx_q for n in joints]
    pos, rot = np.zeros((len(full), 3)), np.zeros((len(full), 3, 3))
    for i, row in enumerate(full):
        q = pin.neutral(model)
        q[slots] = row
        pin.framesForwardKinematics(model, data, q)
        pos[i], rot[i] = data.oMf[frame].translation, data.oMf[frame].rotation
    return pos, rot


@pytest.mark.parametrize(("urdf", "rules", "level", "level_link", "formula"), CASES)
def test_only_leaders_are_controllable_and_bullet_places_every_link_where_the_linkage_does(
        world: World, urdf: Path, rules: tuple[str, ...], level: tuple[str, ...], level_link: str,
        formula: Formula) -> None:
    _load(world, urdf, rules, level)
    model = world.robot_model("arm")
    assert model.controllable == ("joint_1", "joint_2", "joint_3", "joint_5" if urdf == DOBOT else "wrist")
    qs = _draw(world, 200, 1)
    joints, full = _full(model.controllable, qs, formula)
    pos, rot = _pin_frames(urdf, joints, full, model.ee_link)
    for i, q in enumerate(qs):
        pose = world.fk("arm", q)
        assert np.abs(np.array(pose.position) - pos[i]).max() < 1e-4
        assert np.abs(quat_matrix(pose.quat_xyzw) - rot[i]).max() < 2e-3  # 0.1 degree


@pytest.mark.parametrize(("urdf", "rules", "level", "level_link", "formula"), CASES)
def test_ik_reaches_targets_of_the_coupled_fk_with_the_end_level(
        world: World, urdf: Path, rules: tuple[str, ...], level: tuple[str, ...], level_link: str,
        formula: Formula) -> None:
    """200 targets drawn from the coupled FK: reached within 1 mm; the level link's rotation, by Pinocchio
    with the followers set by hand, is the zero configuration's turned about the vertical by joint_1."""
    _load(world, urdf, rules, level)
    model = world.robot_model("arm")
    targets = _draw(world, 200, 2)
    solved = []
    for q in targets:
        pose = world.fk("arm", q)
        res = world.ik("arm", pose.position, pose.quat_xyzw, collision_free=False)
        assert res.position_error < 1e-3 and res.orientation_error < np.radians(1.0)
        solved.append(res.positions)
    joints, full = _full(model.controllable, np.array(solved), formula)
    _, rot = _pin_frames(urdf, joints, full, level_link)
    _, zero = _pin_frames(urdf, joints, np.zeros((1, len(joints))), level_link)
    yaw = np.array(solved)[:, 0]
    turn = np.stack([[[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]]
                     for a in yaw])
    tilt = np.degrees(np.arccos(np.clip((np.einsum("nij,nij->n", rot, turn @ zero[0]) - 1.0) / 2.0, -1, 1)))
    assert tilt.max() < 0.1


def _box_scene(w: World) -> list[tuple[list[float], list[float], list[float]]]:
    """Two boxes in reach of the arms (size, position, orientation), added to the world."""
    boxes = [([0.08, 0.08, 0.1], [0.22, 0.0, 0.05], [0.0, 0.0, 0.0, 1.0]),
             ([0.06, 0.2, 0.04], [0.0, 0.2, 0.25], [0.0, 0.0, 0.0, 1.0])]
    for k, (size, position, quat) in enumerate(boxes):
        w.add_obstacle({"name": f"box{k}", "shape": {"type": "box", "size": size}, "position": position,
                        "orientation": quat})
    return boxes


@pytest.mark.parametrize(("urdf", "rules", "level", "level_link", "formula"), CASES)
def test_labels_match_the_exact_reference_with_the_linkage_applied(
        world: World, urdf: Path, rules: tuple[str, ...], level: tuple[str, ...], level_link: str,
        formula: Formula) -> None:
    """2,000 random leader configurations among two boxes: no configuration the reference calls colliding
    is called free, at most 5 % of the reference-free ones are called colliding. The reference first
    catches a known positive: the end link inside a box."""
    _load(world, urdf, rules, level)
    boxes = _box_scene(world)
    model = world.robot_model("arm")
    qs = _draw(world, 2000, 3)
    joints, full = _full(model.controllable, qs, formula)
    reference = ExactReference(urdf, {}, joints, obstacles=boxes)
    inside = next(i for i, q in enumerate(qs)
                  if np.abs(np.array(world.fk("arm", q).position) - boxes[0][1]).max() < 0.02)
    assert not reference.collision_free(full[inside:inside + 1])[0]
    ours = world.collision_free_batch("arm", qs)
    ref = reference.collision_free(full)
    assert ref.sum() > 200 and (~ref).sum() > 200  # both kinds are exercised
    assert int((ours & ~ref).sum()) == 0
    assert (~ours & ref).sum() <= 0.05 * ref.sum()


def _limited(tmp_path: Path, edit: tuple[str, str]) -> Path:
    text = DOBOT.read_text()
    assert edit[0] in text
    urdf = tmp_path / "dobot_limited.urdf"
    urdf.write_text(text.replace(*edit))
    return urdf


JOINT_4 = '<limit lower="-3.1416" upper="3.1416" velocity="0" effort="10"/>'


def test_a_follower_past_its_limit_is_refused_and_never_sampled(world: World, tmp_path: Path) -> None:
    urdf = _limited(tmp_path, (JOINT_4, '<limit lower="-1.5" upper="1.5" velocity="0" effort="10"/>'))
    _load(world, urdf, (), ("link_4",))
    with pytest.raises(OutOfLimits, match="joint_4"):
        world.set_joint_positions("arm", [0.0, 1.0, 1.0, 0.0])
    world.set_joint_positions("arm", [0.0, 1.0, 0.4, 0.0])
    summary = generate_workspace(world, "arm", samples=3000, seed=4, workers=1, out_dir=tmp_path / "ws",
                                 csv_joints=True)
    rows = np.loadtxt(tmp_path / "ws" / "workspace.csv", delimiter=",", skiprows=1)
    header = (tmp_path / "ws" / "workspace.csv").read_text().splitlines()[0].split(",")
    q2, q3 = rows[:, header.index("joint_2")], rows[:, header.index("joint_3")]
    assert len(rows) < 3000 and np.abs(q2 + q3).max() <= 1.5  # draws the linkage cannot take are left out
    assert summary["collisionFree"] <= len(rows)


def test_a_limited_follower_slows_the_motion_to_its_velocity_limit(world: World, tmp_path: Path) -> None:
    """joint_4 follows -(joint_2 + joint_3): moving both by 0.7 rad turns it 1.4 rad, so at 0.5 rad/s the
    motion lasts at least 2.8 s where the leaders alone (3.14 rad/s) would need well under one."""
    urdf = _limited(tmp_path, (JOINT_4, '<limit lower="-3.1416" upper="3.1416" velocity="0.5" effort="10"/>'))
    _load(world, urdf, (), ("link_4",))
    world.set_joint_positions("arm", [0.0, 0.2, 0.0, 0.0])
    path = world.plan_motion("arm", [0.0, 0.9, 0.7, 0.0], speed=1.0)
    states = path.rows()
    follower = -(states[:, 1] + states[:, 2])
    assert path.duration >= 2.8
    assert np.abs(np.diff(follower)).max() / path.dt <= 0.5 * 1.001


@pytest.mark.parametrize(("rules", "level", "why"), [
    (("joint_4=nope+1",), (), "'nope', which the robot does not have"),
    (("joint_4=joint_3", "joint_3=joint_4"), (), "joint_4 -> joint_3 -> joint_4"),
    (("joint_4=sin(joint_2)",), (), "cannot read"),
    ((), ("link_9",), "link_9"),
])
def test_bad_couplings_are_refused_before_anything_is_loaded(world: World, rules: tuple[str, ...],
                                                            level: tuple[str, ...], why: str) -> None:
    with pytest.raises(InvalidParams) as ei:
        World.read_robot(str(DOBOT), couplings=rules, keep_level=level)
    assert why in str(ei.value)
    assert world.robot_ids() == []


def test_the_scene_document_carries_the_rules_so_a_worker_world_rebuilds_the_same_robot(world: World) -> None:
    """The labelling workers and a restored backend rebuild the world from ``scene_spec``: a coupled robot
    must come back with the same joint vector (it came back with the followers as joints)."""
    _load(world, UARM, UARM_RULES, ("end",))
    spec = world.scene_spec()
    assert spec["robots"][0]["couplings"] == ["end_joint=-joint_2-joint_3", "bar_joint=joint_2+joint_3",
                                               "plate_joint=-joint_2"]
    with World() as other:
        other.load_scene(spec)
        assert other.robot_model("arm").controllable == world.robot_model("arm").controllable
        q = _draw(world, 1, 5)[0]
        assert np.allclose(other.fk("arm", q).position, world.fk("arm", q).position)


def test_a_urdf_without_collision_geometry_is_said_to_check_nothing(tmp_path: Path) -> None:
    """The paper's uArm URDF has visuals only: the twin would call every configuration free."""
    text = DOBOT.read_text()
    bare = "\n".join(line for line in text.splitlines() if "<collision>" not in line)
    urdf = tmp_path / "bare.urdf"
    urdf.write_text(bare)
    files = World.read_robot(str(urdf), keep_level=("link_4",))
    assert any("no link has <collision> geometry" in n for n in files.notes)
    assert not any("no link has <collision>" in n for n in World.read_robot(str(DOBOT)).notes)


@pytest.mark.parametrize(("urdf", "rules", "level", "level_link", "formula"), CASES)
def test_the_workspace_volume_matches_the_reference_s(
        world: World, urdf: Path, rules: tuple[str, ...], level: tuple[str, ...], level_link: str,
        formula: Formula) -> None:
    """The volume of the collision-free end-link positions among two boxes, 4,000 random leader
    configurations: ours (our labels, our FK) within 5 % of the reference's (Pinocchio's FK and Pinocchio +
    Coal's labels with the followers set by hand), both through the same alpha shape at one radius, so
    the difference is the labels' and the FK's."""
    from robwot_sim.workspace.alpha_shape import alpha_shape, auto_alpha

    _load(world, urdf, rules, level)
    boxes = _box_scene(world)
    model = world.robot_model("arm")
    qs = _draw(world, 4000, 5)
    joints, full = _full(model.controllable, qs, formula)
    ours = world.collision_free_batch("arm", qs)
    mine = np.array([world.fk("arm", q).position for q in qs[ours]])
    ref = ExactReference(urdf, {}, joints, obstacles=boxes).collision_free(full)
    theirs, _ = _pin_frames(urdf, joints, full[ref], model.ee_link)
    radius = auto_alpha(theirs)
    volumes = [alpha_shape(points, radius).volume for points in (mine, theirs)]
    assert volumes[1] > 0
    assert abs(volumes[0] - volumes[1]) <= 0.05 * volumes[1], volumes
