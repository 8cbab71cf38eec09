"""Vectorised FK (robwot_sim.model.fk) against PyBullet's link frames (World.fk) and sampling."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from robwot_sim.errors import InvalidParams, UnknownLink, UrdfError
from robwot_sim.model.fk import ChainFK, end_frames
from robwot_sim.model.joints import parse_model
from robwot_sim.model.rotations import quat_matrix, rpy_matrix
from robwot_sim.model.urdf import parse_urdf
from robwot_sim.sim.world import World
from robwot_sim.workspace.generate import chain_fk
from robwot_sim.workspace.sampling import BLOCK, sample_configurations

MODELS = Path(__file__).parent / "models" / "workspace"
BASE_POS = (0.3, -0.2, 0.1)
BASE_QUAT = (0.1, 0.2, 0.3, 0.9)  # normalised by the loader and by the FK alike


def _chain(urdf: Path, ee: str, controllable: list[str]) -> ChainFK:
    """The chain of a URDF file from the one joint-tree parser."""
    model = parse_model(parse_urdf(urdf))
    return ChainFK.from_joints(model.joints, model.links, ee, controllable, model.couplings)


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    with World() as w:
        yield w


@pytest.mark.parametrize("urdf", [
    "kuka_iiwa/model.urdf", "franka_panda/panda.urdf", "xarm/xarm6_robot.urdf",
    str(MODELS / "chain_mimic.urdf"), str(MODELS / "shell.urdf"), str(MODELS / "planar2.urdf"),
])
def test_fk_matches_pybullet(world: World, urdf: str) -> None:
    """Vectorised FK, by matrices (``poses``) and coordinate by coordinate (``end_frames``), equals
    PyBullet's end-effector link frame (< 1e-6 m, < 1e-6 in rotation) at random q."""
    rid = Path(urdf).stem + "-fk"
    model = world.load_robot(urdf, robot_id=rid, base_position=BASE_POS, base_orientation=BASE_QUAT)
    try:
        fk = chain_fk(world, rid)
        lo, hi = model.limits()
        qs = sample_configurations(lo, hi, 40, seed=7)
        pos, rot = fk.poses(qs)
        epos, erot = end_frames(fk, qs)
        for i, q in enumerate(qs):
            pose = world.fk(rid, q)
            for p, r in ((pos[i], rot[i]), (epos[i], erot[i])):
                assert np.abs(np.array(pose.position) - p).max() < 1e-6
                assert np.abs(quat_matrix(pose.quat_xyzw) - r).max() < 1e-6
        assert np.allclose(fk.positions(qs), pos)
    finally:
        world.remove_robot(rid)


def test_fk_base_pose_moves_points(world: World) -> None:
    """The base pose is applied: the same q differs by the base transform between two placements."""
    a = world.load_robot("kuka_iiwa/model.urdf", robot_id="kuka-a")
    b = world.load_robot("kuka_iiwa/model.urdf", robot_id="kuka-b", base_position=BASE_POS,
                         base_orientation=BASE_QUAT)
    try:
        lo, hi = a.limits()
        qs = sample_configurations(lo, hi, 10, seed=3)
        pa = chain_fk(world, "kuka-a").positions(qs)
        pb = chain_fk(world, "kuka-b").positions(qs)
        expected = pa @ quat_matrix(BASE_QUAT).T + np.array(BASE_POS)
        assert np.abs(pb - expected).max() < 1e-12
        assert b.base_position == pytest.approx(BASE_POS)
    finally:
        world.remove_robot("kuka-a")
        world.remove_robot("kuka-b")


def test_fk_mimic_follows_master() -> None:
    """A mimic joint on the chain moves with its master (multiplier and offset) without a vector entry."""
    fk = _chain(MODELS / "chain_mimic.urdf", "tool", ["base_yaw", "spin", "slide"])
    follower = next(j for j in fk.joints if j.name == "follower")
    assert (follower.terms, follower.offset) == (((0, 0.5),), 0.2)
    assert fk.dof == 3


def test_fk_unknown_link_lists_links() -> None:
    """An unknown end-effector link is refused with the available names."""
    with pytest.raises(UnknownLink) as exc:
        _chain(MODELS / "shell.urdf", "nope", ["yaw", "pitch", "radial"])
    assert "tip" in exc.value.data["available"]


def test_rpy_matches_fixed_axis_convention() -> None:
    """URDF rpy is Rz(yaw) Ry(pitch) Rx(roll): a pure yaw of pi/2 maps x onto y."""
    assert np.allclose(rpy_matrix(0, 0, np.pi / 2) @ [1, 0, 0], [0, 1, 0])
    assert np.allclose(rpy_matrix(np.pi / 2, 0, 0) @ [0, 1, 0], [0, 0, 1])


def test_sampling_seeded_and_within_limits() -> None:
    """Same seed gives the same configurations; all lie within the limits; another seed differs."""
    lo, hi = np.array([-1.0, 0.05, -3.0]), np.array([2.0, 0.25, 3.0])
    a = sample_configurations(lo, hi, 5000, seed=1)
    assert a.shape == (5000, 3)
    assert np.array_equal(a, sample_configurations(lo, hi, 5000, seed=1))
    assert not np.array_equal(a, sample_configurations(lo, hi, 5000, seed=2))
    assert (a >= lo).all() and (a <= hi).all()
    assert np.allclose(a.mean(axis=0), (lo + hi) / 2, atol=0.05 * (hi - lo))


def test_sampling_any_split_gives_the_same_rows() -> None:
    """Rows depend only on (seed, row): any range drawn alone (a chunk on a worker or a Ray task) equals
    the same rows of one draw, across block boundaries; blocks are independent streams."""
    lo, hi = np.array([-1.0, 0.05, -3.0]), np.array([2.0, 0.25, 3.0])
    whole = sample_configurations(lo, hi, 5 * BLOCK + 17, seed=4)
    for start, count in ((0, 1), (3, 500), (BLOCK - 1, 2), (BLOCK, BLOCK),
                         (2 * BLOCK + 333, 2 * BLOCK + 684)):
        assert np.array_equal(sample_configurations(lo, hi, count, seed=4, start=start),
                              whole[start:start + count])
    parts = [sample_configurations(lo, hi, n, seed=4, start=a)
             for a, n in ((0, 777), (777, 2500), (3277, len(whole) - 3277))]
    assert np.array_equal(np.concatenate(parts), whole)
    assert not np.array_equal(whole[:BLOCK], whole[BLOCK:2 * BLOCK])
    with pytest.raises(InvalidParams):
        sample_configurations(lo, hi, 10, seed=4, start=-1)


def test_sampling_refuses_bad_limits() -> None:
    """Infinite or inverted limits are refused with the joint index."""
    with pytest.raises(InvalidParams):
        sample_configurations([0.0], [np.inf], 10, seed=1)
    with pytest.raises(InvalidParams):
        sample_configurations([1.0], [0.0], 10, seed=1)


def test_fk_blocks_equal_one_pass() -> None:
    """Block-wise FK (bounded memory) gives the same positions as one pass."""
    fk = _chain(MODELS / "chain_mimic.urdf", "tool", ["base_yaw", "spin", "slide"])
    qs = sample_configurations([-2.5, -3.14, -0.1], [2.5, 3.14, 0.2], 2500, seed=9)
    assert np.array_equal(fk.positions(qs, block=1000), fk.poses(qs)[0])


@pytest.mark.parametrize("urdf, ee, joints", [
    (MODELS / "chain_mimic.urdf", "tool", ["base_yaw", "spin", "slide"]),
    (MODELS / "planar2.urdf", None, None),
])
def test_end_frames_of_a_row_do_not_depend_on_its_batch(urdf: Path, ee: str | None,
                                                        joints: list[str] | None) -> None:
    """A generation's end-link poses (``end_frames``) are the same bits for a row whatever batch it is in
    (its files are the same for any split into chunks): rows alone, in batches of 7 and in one batch."""
    if ee is None or joints is None:
        model = parse_model(parse_urdf(urdf))
        joints = [j.name for j in model.joints if j.type != "fixed"]
        ee = model.links[-1]
    fk = _chain(urdf, ee, joints)
    qs = sample_configurations([-2.5] * len(joints), [2.5] * len(joints), 300, seed=4)
    whole = end_frames(fk, qs)
    for size in (1, 7):
        parts = [end_frames(fk, qs[a:a + size]) for a in range(0, len(qs), size)]
        for k in range(2):
            assert np.array_equal(np.concatenate([part[k] for part in parts]), whole[k])


def test_joint_tree_refuses_a_malformed_origin_with_its_line(tmp_path: Path) -> None:
    """The one joint-tree parser checks origins and axes, naming file, line and joint."""
    urdf = tmp_path / "bad.urdf"
    urdf.write_text('<robot name="r">\n<link name="a"/>\n<link name="b"/>\n'
                    '<joint name="j" type="revolute">\n<parent link="a"/>\n<child link="b"/>\n'
                    '<origin xyz="0 0 oops"/>\n<limit lower="-1" upper="1"/>\n</joint>\n</robot>\n')
    with pytest.raises(UrdfError, match="must be 3 finite numbers") as ei:
        parse_model(parse_urdf(urdf))
    assert ei.value.data["line"] == 7 and ei.value.data["joint"] == "j"
