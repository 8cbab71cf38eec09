"""The world split by job: a `Scene` holds the bodies, their states and versions on its own; the batch
collision queries, IK, path checks, timing and detours are parts over it (``World`` only composes them);
the detours remembered are per robot and per version of the scene; a program step's defaults come from the
contract where the request enters."""

from __future__ import annotations

import numpy as np
import pytest
from simhelp import DATA, KUKA, MODELS, PANDA

from robwot_sim import limits
from robwot_sim.errors import UnknownRobot
from robwot_sim.rpc.contract import contract
from robwot_sim.sim import pathcheck, trajectory
from robwot_sim.sim.collision_queries import CollisionQueries
from robwot_sim.sim.detour import DetourMemory
from robwot_sim.sim.ik import ik
from robwot_sim.sim.planning_scene import Scene
from robwot_sim.sim.world import World

START = [0.0, 0.6, 0.0, -1.2, 0.0, 0.6, 0.0]
BOX = {"name": "box", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]}, "position": [0.6, 0.0, 0.5]}


def test_a_scene_alone_holds_bodies_states_and_versions() -> None:
    """Without a World: bodies added, moved and removed bump the version, a robot's own joints only its
    stamp for others; hypothetical states end where they began; an unknown robot is named."""
    with Scene() as scene:
        m = scene.load_robot(KUKA)
        before, stamp = scene.version, scene.others_stamp(m.id)
        scene.add_obstacle(BOX)
        assert scene.version == before + 1 and scene.others_stamp(m.id) != stamp
        stamp = scene.others_stamp(m.id)
        scene.set_joint_positions(m.id, START)
        assert scene.others_stamp(m.id) == stamp and scene.version == before + 1
        with scene.hypothetical(m.id):
            scene.place(m.id, [0.0] * m.dof)
            assert scene.get_joint_positions(m.id) == pytest.approx([0.0] * m.dof)
        assert scene.get_joint_positions(m.id) == pytest.approx(START)
        scene.move_obstacle("box", [0.6, 0.1, 0.5])
        assert scene.list()["obstacles"][0]["position"] == [0.6, 0.1, 0.5]
        scene.remove_robot(m.id)
        with pytest.raises(UnknownRobot):
            scene.entry(m.id)


def test_a_robot_loaded_again_finds_its_always_colliding_pairs_again() -> None:
    """PyBullet keeps a removed body's pair filters under its id: the body next given that id starts with
    none (the Panda's link7/hand pair, touching in every configuration, is found and filtered each time)."""
    with Scene() as scene:
        for _ in range(2):
            m = scene.load_robot(DATA / PANDA, robot_id="panda")
            assert m.filtered_pairs == (("panda_link7", "panda_hand"),)
            scene.remove_robot("panda")


def test_the_parts_over_a_scene_give_the_worlds_answers() -> None:
    """Batch queries, IK, timing and path checks over a bare scene answer as the World composing them."""
    qs = np.random.default_rng(3).uniform(-1.0, 1.0, (40, 7))
    with Scene() as scene, World() as world:
        for s in (scene, world):
            s.load_robot(KUKA, robot_id="kuka")
            s.add_obstacle(BOX)
        queries = CollisionQueries(scene)
        try:
            assert np.array_equal(queries.free_batch("kuka", qs), world.collision_free_batch("kuka", qs))
        finally:
            queries.close()
        pose = world.fk("kuka", START)
        assert ik(scene, "kuka", pose.position) == world.ik("kuka", pose.position)
        path = trajectory.plan_motion(scene, "kuka", START, speed=0.5)
        assert np.array_equal(path.rows(), world.plan_motion("kuka", START, speed=0.5).rows())
        assert pathcheck.check_path(scene, "kuka", START) == world.check_path("kuka", START)
        assert world.queries is not None and world.scene.robot_ids() == ["kuka"]


def test_detours_are_remembered_per_robot_for_the_current_version() -> None:
    """A detour is found again only for its robot, between its states, in the version it was found in;
    remembering one in a newer version drops every older one."""
    memory = DetourMemory()
    a, b, c = (np.full(2, v) for v in (0.0, 0.5, 1.0))
    memory.remember("r1", 1, [a, b, c])
    assert len(memory.stretches("r1", 1, a, c)) == 1 and memory.stretches("r2", 1, a, c) == []
    back = memory.stretches("r1", 1, c, a)[0]
    assert np.array_equal(back[0], a) and np.array_equal(back[-1], c)  # in the order it was found
    assert memory.stretches("r1", 2, a, c) == []
    memory.remember("r2", 2, [c, a])
    assert memory.stretches("r1", 1, a, c) == [] and len(memory.stretches("r2", 2, c, a)) == 1


def test_a_program_steps_defaults_are_the_contracts() -> None:
    """A step given only its target reads the contract's defaults (speed, acceleration, TCP speed,
    blend radius, motion) once the request is checked; given values are kept."""
    values = contract().validate_params("program.plan", {"robot": "r", "steps": [
        {"target": [0.0]}, {"position": [0.5, 0, 0.5], "motion": "lin", "speed": 0.5}]})
    first, second = values["steps"]
    schemas = contract().document["components"]["schemas"]
    assert first == {"target": [0.0], "motion": "ptp", "speed": limits.DEFAULT_SPEED,
                     "acceleration": limits.DEFAULT_ACCELERATION, "tcpSpeed": limits.DEFAULT_TCP_SPEED,
                     "blend": schemas["BlendRadius"]["default"]}
    assert second["speed"] == 0.5 and second["motion"] == "lin"
    assert "dt" not in values and "rate" not in values  # a param's own default stays the params'


def test_a_world_is_its_parts() -> None:
    """The World's answers come from its scene: a robot loaded through one is the other's."""
    with World() as w:
        m = w.load_robot(MODELS / "planar2.urdf")
        assert w.scene.robot_model(m.id) is w.robot_model(m.id)
        w.set_joint_positions(m.id, [0.1, 0.2])
        assert w.scene.get_joint_positions(m.id) == pytest.approx([0.1, 0.2])
