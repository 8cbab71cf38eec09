"""World API: joint model, state, obstacles, validation that never changes the world (H1)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from simhelp import KUKA, MODELS, PANDA, XARM

from robwot_sim.errors import (
    InvalidParams,
    NameTaken,
    OutOfLimits,
    UnknownLink,
    UnknownObject,
    UnknownRobot,
)
from robwot_sim.sim.world import World


@pytest.mark.parametrize(
    ("urdf", "ee", "dof"), [(KUKA, "lbr_iiwa_link_7", 7), (PANDA, "panda_hand", 8), (XARM, "link6", 6)]
)
def test_default_end_effector_and_controllable(urdf: str, ee: str, dof: int) -> None:
    """The default end effector is the tip of the longest serial chain; mimic joints are not controllable."""
    with World() as w:
        m = w.load_robot(urdf)
        assert m.ee_link == ee
        assert m.dof == dof
        assert "panda_finger_joint2" not in m.controllable


def test_joint_model_of_tiny_urdfs() -> None:
    """Limits, velocity, effort, types and mimic come from the URDF; JSON matches Contract 1."""
    with World() as w:
        m = w.load_robot(MODELS / "prismatic.urdf")
        rail = m.joint("rail")
        assert (rail.type, rail.lower, rail.upper, rail.velocity, rail.effort) == (
            "prismatic",
            -0.2,
            0.4,
            0.5,
            100,
        )
        mm = w.load_robot(MODELS / "mimic.urdf")
        js = {j["name"]: j for j in mm.to_json()["joints"]}
        assert js["finger_mimic"]["mimic"] == {"joint": "finger", "multiplier": -0.5, "offset": 0.1}
        assert mm.to_json()["controllable"] == ["finger"]
        c = w.load_robot(MODELS / "continuous.urdf").to_json()
        assert c["joints"][0]["lower"] == -math.pi and c["joints"][0]["type"] == "continuous"
        assert set(c) >= {
            "id",
            "name",
            "urdf",
            "eeLink",
            "links",
            "joints",
            "controllable",
            "filteredPairs",
            "basePosition",
            "baseOrientation",
        }


def test_robot_ids_unique_and_names_taken() -> None:
    """Ids derive from the URDF name and are made unique; an explicit taken id is refused."""
    with World() as w:
        assert w.load_robot(KUKA).id == "lbr_iiwa"
        assert w.load_robot(KUKA, base_position=(2, 0, 0)).id == "lbr_iiwa-2"
        with pytest.raises(NameTaken):
            w.load_robot(KUKA, robot_id="lbr_iiwa")
        w.add_obstacle({"name": "box", "shape": {"type": "sphere", "radius": 0.1}, "position": [3, 3, 3]})
        with pytest.raises(NameTaken):
            w.add_obstacle({"name": "box", "shape": {"type": "sphere", "radius": 0.1}, "position": [3, 3, 3]})
        with pytest.raises(NameTaken):
            w.load_robot(KUKA, robot_id="box")
        assert len(w.list()["robots"]) == 2 and len(w.list()["obstacles"]) == 1


def test_set_joint_positions_validates_before_changing() -> None:
    """NaN, wrong length, wrong type and out-of-limit vectors are refused and the state is kept."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.set_joint_positions(m.id, [0.1] * 7)
        for bad, err in [
            ([float("nan")] * 7, InvalidParams),
            ([0.1] * 6, InvalidParams),
            (["a"] * 7, InvalidParams),
            ([0.1, 0.1, 0.1, 3.0, 0.1, 0.1, 0.1], OutOfLimits),
            ([float("inf")] * 7, InvalidParams),
            ([True] * 7, InvalidParams),
        ]:
            with pytest.raises(err) as ei:
                w.set_joint_positions(m.id, bad)
            assert np.allclose(w.get_joint_positions(m.id), 0.1)
        assert ei.type is InvalidParams
        with pytest.raises(OutOfLimits) as lim:
            w.set_joint_positions(m.id, [0.1, 0.1, 0.1, 3.0, 0.1, 0.1, 0.1])
        assert lim.value.data == {
            "joint": "lbr_iiwa_joint_4",
            "value": 3.0,
            "lower": -2.09439510239,
            "upper": 2.09439510239,
        }


def test_unknown_names_list_available() -> None:
    """Unknown robot/object/link errors name the available ones."""
    with World() as w:
        w.load_robot(KUKA, robot_id="k")
        with pytest.raises(UnknownRobot) as r:
            w.fk("nope")
        assert r.value.data["available"] == ["k"]
        with pytest.raises(UnknownObject):
            w.remove_obstacle("ghost")
        with pytest.raises(UnknownObject):
            w.move_obstacle("ghost", (0, 0, 0))
        with pytest.raises(UnknownLink) as ln:
            w.load_robot(KUKA, ee_link="nope")
        assert "lbr_iiwa_link_7" in ln.value.data["available"]
        assert w.robot_ids() == ["k"]


def test_obstacles_add_move_remove_and_reset() -> None:
    """Obstacles are normalised (rpy -> quaternion), moved, removed; reset empties the world."""
    with World() as w:
        w.load_robot(KUKA)
        ob = w.add_obstacle(
            {
                "name": "c",
                "shape": {"type": "cylinder", "radius": 0.05, "length": 0.2},
                "position": [1, 0, 0.1],
                "rpy": [0, 0, math.pi / 2],
            }
        )
        assert ob["orientation"] == pytest.approx([0, 0, math.sqrt(0.5), math.sqrt(0.5)])
        moved = w.move_obstacle("c", (1, 1, 0.1), orientation=(0, 0, 0, 2))
        assert moved["orientation"] == [0, 0, 0, 1] and moved["position"] == [1, 1, 0.1]
        with pytest.raises(InvalidParams):
            w.move_obstacle("c", (1, float("nan"), 0))
        with pytest.raises(InvalidParams):
            w.add_obstacle(
                {"name": "bad", "shape": {"type": "box", "size": [0.1, -1, 0.1]}, "position": [0, 0, 0]}
            )
        assert w.list()["obstacles"][0]["position"] == [1, 1, 0.1]
        w.remove_obstacle("c")
        assert w.list()["obstacles"] == []
        w.add_obstacle(
            {
                "name": "m",
                "shape": {"type": "mesh", "file": str(MODELS / "meshes" / "cube.obj")},
                "position": [0.6, 0, 0.5],
            }
        )
        w.reset()
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


def test_export_robot_is_self_contained(tmp_path) -> None:
    """Export writes robot.urdf with relative mesh paths that load again from the new folder."""
    with World() as w:
        m = w.load_robot(
            MODELS / "pkgtest" / "urdf" / "robot.urdf", package_roots={"shared": str(MODELS / "shared")}
        )
        out = w.export_robot(m.id, tmp_path / "twin")
        assert out["urdf"] == "robot.urdf" and all(p.startswith("meshes/") for p in out["meshes"])
        text = (tmp_path / "twin" / "robot.urdf").read_text()
        assert "package://" not in text and str(MODELS) not in text
        again = w.load_robot(tmp_path / "twin" / "robot.urdf")
        assert again.controllable == m.controllable
        pk = w.load_robot(PANDA, base_position=(3, 0, 0))
        meshes = w.export_robot(pk.id, tmp_path / "panda")["meshes"]
        assert "meshes/collision/link0.obj" in meshes and "meshes/visual/link1.obj" in meshes
        for companion in ("link1.mtl", "colors.png"):  # OBJ material library and its texture
            assert (tmp_path / "panda" / "meshes" / "visual" / companion).is_file()
        kk = w.load_robot(KUKA, base_position=(5, 0, 0))
        w.export_robot(kk.id, tmp_path / "kuka")
        assert (tmp_path / "kuka" / "meshes" / "link_0.mtl").is_file()  # OBJ material library copied
        again = w.load_robot(tmp_path / "panda" / "robot.urdf", base_position=(7, 0, 0))
        assert again.filtered_pairs == pk.filtered_pairs
