"""Joint couplings (model/couplings.py): the rules read, flattened and derived, and the coupled FK against
Pinocchio's FK of the same URDF with the followers set by hand-written formulas."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from robwot_sim.errors import InvalidParams
from robwot_sim.model.couplings import keep_level, parse_coupling, passive_hints
from robwot_sim.model.fk import ChainFK
from robwot_sim.model.joints import UrdfModel, parse_model
from robwot_sim.model.urdf import parse_urdf

ROBOTS = Path(__file__).resolve().parents[2] / "examples" / "robots"
MODELS = Path(__file__).parent / "models"
Rule = Callable[[dict[str, np.ndarray]], np.ndarray]


def _model(path: Path) -> UrdfModel:
    return parse_model(parse_urdf(path))


@pytest.mark.parametrize(("text", "expression", "terms", "offset"), [
    ("joint_4=joint_3-joint_2", "joint_4=joint_3-joint_2", (("joint_3", 1.0), ("joint_2", -1.0)), 0.0),
    (" a = -0.5*J2 + J3 + 0.1 ", "a=-0.5*J2+J3+0.1", (("J2", -0.5), ("J3", 1.0)), 0.1),
    ("d/j4=d/j3*2-d/j2-1e-3", "d/j4=2*d/j3-d/j2-0.001", (("d/j3", 2.0), ("d/j2", -1.0)), -0.001),
    ("x=J2+J2-2*J2+0.5", "x=0.5", (), 0.5),
    ("x=--J2", "x=J2", (("J2", 1.0),), 0.0),
])
def test_rules_are_read_as_linear_combinations(text: str, expression: str,
                                               terms: tuple[tuple[str, float], ...], offset: float) -> None:
    c = parse_coupling(text)
    assert (c.expression, c.terms, c.offset) == (expression, terms, offset)
    assert parse_coupling(c.expression) == c


@pytest.mark.parametrize(("text", "why"), [
    ("x=J2*J3", "a '*' joins one number and one joint"),
    ("x=2*3", "a '*' joins one number and one joint"),
    ("x=sin(J2)", "cannot read '(J2)'"),
    ("x=", "an expression after '='"),
    ("=J2", "FOLLOWER a joint name"),
    ("J2", "FOLLOWER a joint name"),
    ("x=J2 J3", "terms joined by '+' or '-'"),
    ("x=J2+", "a number or a joint name after each sign"),
    ("x=J2+" + "J3+" * 400 + "J4", "at most 1024 characters"),
    ("x=" + "+".join(["J2"] * 65), "at most 64 terms"),
    ("x=1e999*J2", "finite numbers"),
])
def test_a_rule_that_is_not_linear_is_refused_saying_why(text: str, why: str) -> None:
    with pytest.raises(InvalidParams, match="couplings") as ei:
        parse_coupling(text)
    assert why in str(ei.value)


def test_followers_of_followers_are_flattened_into_the_leaders() -> None:
    model = _model(ROBOTS / "uarm_like.urdf")
    coupled = model.coupled(["plate_joint=-0.5*bar_joint+0.1", "bar_joint=2*joint_2+joint_3"])
    rules = {c.follower: c for c in coupled.couplings}
    assert rules["plate_joint"].terms == (("joint_2", -1.0), ("joint_3", -0.5))
    assert rules["plate_joint"].offset == pytest.approx(0.1)
    assert "plate_joint" not in coupled.controllable and "bar_joint" not in coupled.controllable


@pytest.mark.parametrize(("rules", "why"), [
    (["bar_joint=plate_joint", "plate_joint=bar_joint+1"], "bar_joint -> plate_joint -> bar_joint"),
    (["bar_joint=bar_joint"], "bar_joint -> bar_joint"),
    (["bar_joint=joint_9"], "'joint_9', which the robot does not have"),
    (["nope=joint_2"], "'nope', which the robot does not have"),
    (["bar_joint=joint_2", "bar_joint=joint_3"], "'bar_joint' is coupled twice"),
    ([f"{j}=0" for j in ("joint_1", "joint_2", "joint_3", "end_joint", "wrist", "bar_joint", "plate_joint")],
     "none is left to control"),
])
def test_bad_couplings_are_refused_naming_the_joints(rules: list[str], why: str) -> None:
    with pytest.raises(InvalidParams) as ei:
        _model(ROBOTS / "uarm_like.urdf").coupled(rules)
    assert why in str(ei.value)


def test_a_fixed_joint_can_neither_follow_nor_lead(tmp_path: Path) -> None:
    urdf = tmp_path / "fixed.urdf"
    urdf.write_text((ROBOTS / "dobot_like.urdf").read_text().replace(
        '<joint name="joint_5" type="revolute">', '<joint name="joint_5" type="fixed">'))
    for rule in ("joint_5=joint_2", "joint_4=joint_5"):
        with pytest.raises(InvalidParams, match="the fixed joint 'joint_5'"):
            _model(urdf).coupled([rule])


def test_mimic_tags_are_one_leader_couplings_and_a_rule_replaces_one() -> None:
    model = _model(MODELS / "mimic.urdf")
    assert model.controllable == ("finger",)
    assert [c.to_json() for c in model.couplings] == [{
        "follower": "finger_mimic", "terms": [{"joint": "finger", "factor": -0.5}], "offset": 0.1,
        "source": "mimic", "expression": "finger_mimic=-0.5*finger+0.1"}]
    replaced = model.coupled(["finger_mimic=-finger"])
    assert [c.expression for c in replaced.couplings] == ["finger_mimic=-finger"]


def test_keep_level_derives_the_parallelogram_rule_of_a_dobot_like_arm() -> None:
    model = _model(ROBOTS / "dobot_like.urdf")
    rule = keep_level("link_4", model.joints)
    assert (rule.expression, rule.source) == ("joint_4=-joint_2-joint_3", "keep-level")
    coupled = model.coupled(level_links=["link_4"])
    assert coupled.controllable == ("joint_1", "joint_2", "joint_3", "joint_5")


def test_keep_level_follows_axis_directions(tmp_path: Path) -> None:
    """A joint whose axis points the other way along the common axis enters with the other sign."""
    urdf = tmp_path / "flipped.urdf"
    urdf.write_text((ROBOTS / "dobot_like.urdf").read_text().replace(
        '<origin xyz="0 0 0.135"/><axis xyz="0 1 0"/>', '<origin xyz="0 0 0.135"/><axis xyz="0 -1 0"/>'))
    assert keep_level("link_4", _model(urdf).joints).expression == "joint_4=-joint_2+joint_3"


@pytest.mark.parametrize(("link", "edit", "why"), [
    ("base_link", None, "is the root link or not a link"),
    ("link_2", None, "two or more tilting joints"),
    ("link_4", ('0.147 0 0"/><axis xyz="0 1 0"/>', '0.147 0 0"/><axis xyz="1 0 0"/>'),
     "turn about different axes"),
    ("link_5", ('0 0 0.024"/><axis xyz="0 0 1"/>', '0 0 0.024"/><axis xyz="0 1 0"/>'),
     "turns about the vertical after"),
])
def test_keep_level_refuses_what_no_linear_rule_keeps_level(tmp_path: Path, link: str,
                                                            edit: tuple[str, str] | None, why: str) -> None:
    text = (ROBOTS / "dobot_like.urdf").read_text()
    if edit is not None:
        assert edit[0] in text
        text = text.replace(*edit)
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(text)
    with pytest.raises(InvalidParams, match="keepLevel") as ei:
        keep_level(link, _model(urdf).joints)
    assert why in str(ei.value)


def test_passive_looking_joints_are_named_with_why() -> None:
    model = _model(ROBOTS / "uarm_like.urdf")
    hints = dict(passive_hints(model.joints, {j.name: j.velocity for j in model.joints}, set(),
                               {j.name: j.origin_xyz for j in model.joints}, {"end_joint"}))
    assert set(hints) == {"bar_joint", "plate_joint"}
    assert "velocity limit is 0" in hints["bar_joint"]
    assert "same point of 'turntable' as 'joint_2'" in hints["bar_joint"]
    assert "same point of 'upper_arm' as 'joint_3'" in hints["plate_joint"]


def _reference_fk(urdf: Path, full: dict[str, np.ndarray], link: str) -> tuple[np.ndarray, np.ndarray]:
    """Positions and rotations of ``link`` by Pinocchio for full joint configurations (joint -> values)."""
    pin = pytest.importorskip("pinocchio")
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    frame = model.getFrameId(link)
    n = len(next(iter(full.values())))
    pos, rot = np.zeros((n, 3)), np.zeros((n, 3, 3))
    for i in range(n):
        q = pin.neutral(model)
        for name, values in full.items():
            q[model.joints[model.getJointId(name)].idx_q] = values[i]
        pin.framesForwardKinematics(model, data, q)
        pos[i], rot[i] = data.oMf[frame].translation, data.oMf[frame].rotation
    return pos, rot


@pytest.mark.parametrize(("urdf", "rules", "level", "link", "followers"), [
    ("dobot_like.urdf", [], ["link_4"], "link_5",
     {"joint_4": lambda q: -q["joint_2"] - q["joint_3"]}),
    ("uarm_like.urdf", ["bar_joint=joint_2+joint_3", "plate_joint=-joint_2"], ["end"], "tool",
     {"end_joint": lambda q: -q["joint_2"] - q["joint_3"]}),
    ("uarm_like.urdf", ["bar_joint=joint_2+joint_3", "plate_joint=-joint_2"], ["end"], "drive_bar",
     {"bar_joint": lambda q: q["joint_2"] + q["joint_3"]}),
])
def test_coupled_fk_matches_pinocchio_and_keeps_the_end_level(urdf: str, rules: list[str], level: list[str],
                                                              link: str, followers: dict[str, Rule]) -> None:
    """1,000 random leader configurations: the coupled FK equals Pinocchio's FK with the followers set by
    the linkage's own formula (< 0.1 mm, < 0.1 degree); the end stays level (its rotation is the zero
    configuration's turned about the vertical by joint_1)."""
    model = _model(ROBOTS / urdf).coupled(rules, level)
    fk = ChainFK.from_joints(model.joints, model.links, link, model.controllable, model.couplings)
    rng = np.random.default_rng(36)
    joints = {j.name: j for j in model.joints}
    qs = np.stack([rng.uniform(joints[n].lower, joints[n].upper, 1000) for n in model.controllable], axis=1)
    by_name = {n: qs[:, i] for i, n in enumerate(model.controllable)}
    full = {**by_name, **{f: rule(by_name) for f, rule in followers.items()}}
    pos, rot = fk.poses(qs)
    ref_pos, ref_rot = _reference_fk(ROBOTS / urdf, full, link)
    assert np.abs(pos - ref_pos).max() < 1e-4
    cos = (np.einsum("nij,nij->n", rot, ref_rot) - 1.0) / 2.0
    assert np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max() < 0.1
    if link in ("link_5", "tool"):
        level_link = "link_4" if link == "link_5" else "end"
        level_fk = ChainFK.from_joints(model.joints, model.links, level_link, model.controllable,
                                       model.couplings)
        zero = level_fk.poses(np.zeros((1, len(model.controllable))))[1][0]
        yaw = by_name["joint_1"]
        turn = np.stack([np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
                         for a in yaw])
        assert np.abs(level_fk.poses(qs)[1] - turn @ zero).max() < 1e-9


def test_a_joint_that_states_no_velocity_limit_is_not_suspect() -> None:
    """A continuous joint without ``<limit>`` states no velocity: only a stated 0 looks passive."""
    model = _model(ROBOTS / "dobot_like.urdf")
    origins = {j.name: j.origin_xyz for j in model.joints}
    stated = {j.name: j.velocity for j in model.joints if j.name != "joint_4"}
    assert passive_hints(model.joints, stated, set(), origins, set()) == []
    stated["joint_4"] = 0.0
    assert [n for n, _ in passive_hints(model.joints, stated, set(), origins, set())] == ["joint_4"]
