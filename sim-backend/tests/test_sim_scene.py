"""Scene documents: schema errors with JSON pointers, example scenes, round trip (H1)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from simhelp import KUKA, MODELS, SCENES

from robwot_bench import scenegen
from robwot_sim.errors import FileNotFound, SceneError
from robwot_sim.sim.world import World


@pytest.mark.parametrize(
    ("doc", "pointer"),
    [
        ({"version": 2}, "/version"),
        (
            {
                "version": 1,
                "obstacles": [{"name": "a", "shape": {"type": "box", "size": [1, 1]}, "position": [0, 0, 0]}],
            },
            "/obstacles/0/shape/size",
        ),
        (
            {
                "version": 1,
                "obstacles": [{"name": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0]}],
            },
            "/obstacles/0/position",
        ),
        (
            {
                "version": 1,
                "obstacles": [
                    {"name": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, float("nan")]}
                ],
            },
            "/obstacles/0/position/2",
        ),
        (
            {
                "version": 1,
                "obstacles": [
                    {"name": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0]},
                    {"name": "a", "shape": {"type": "sphere", "radius": 1}, "position": [0, 0, 0]},
                ],
            },
            "/obstacles/1/name",
        ),
        ({"version": 1, "robots": [{"basePosition": [0, 0, 0]}]}, "/robots/0"),
        ({"version": 1, "extra": 1}, ""),
    ],
)
def test_schema_violations_give_json_pointer(doc: dict, pointer: str) -> None:
    """Each violation is a SceneError whose data.path is the JSON pointer of the bad value."""
    with World() as w:
        with pytest.raises(SceneError) as ei:
            w.load_scene(doc)
        assert ei.value.data["path"] == pointer
        assert ei.value.rpc_code == -32006
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


def test_scene_file_errors(tmp_path) -> None:
    """A missing file is FileNotFound, invalid JSON and NaN literals are SceneErrors naming the file."""
    with World() as w:
        with pytest.raises(FileNotFound):
            w.load_scene(tmp_path / "none.json")
        bad = tmp_path / "bad.json"
        bad.write_text('{"version": 1, "obstacles": [NaN]}')
        with pytest.raises(SceneError) as ei:
            w.load_scene(bad)
        assert ei.value.data["file"] == str(bad)


@pytest.mark.parametrize("depth", [65, 100_000])
def test_scene_file_nested_too_deep_is_a_scene_error(tmp_path, depth: int) -> None:
    """A scene file nesting arrays deeper than the JSON depth limit is refused naming the file and the
    limit (a 10^5-deep one used to end in an internal RecursionError), and the world stays empty."""
    deep = tmp_path / "deep.json"
    deep.write_text('{"version": 1, "obstacles": ' + "[" * depth + "]" * depth + "}")
    with World() as w:
        with pytest.raises(SceneError, match="deeper than 64 levels") as ei:
            w.load_scene(deep)
        assert ei.value.data["file"] == str(deep)
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


def test_failed_scene_leaves_world_unchanged(tmp_path) -> None:
    """A scene whose robot URDF is missing adds nothing (all or nothing)."""
    doc = {
        "version": 1,
        "obstacles": [{"name": "a", "shape": {"type": "sphere", "radius": 0.1}, "position": [1, 1, 1]}],
        "robots": [{"urdf": "missing/robot.urdf"}],
    }
    with World() as w:
        with pytest.raises(FileNotFound):
            w.load_scene(doc)
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


@pytest.mark.parametrize("n", scenegen.SIZES)
def test_example_scenes_are_generated_and_leave_free_space(n: int) -> None:
    """obstacles-N.json has N obstacles, equals the generator output, spares the base, leaves space free."""
    path = SCENES / f"obstacles-{n}.json"
    assert json.loads(path.read_text()) == json.loads(json.dumps(scenegen.obstacles_scene(n)))
    with World() as w:
        m = w.load_robot(KUKA)
        out = w.load_scene(path)
        assert len(out["obstacles"]) == n
        e = w.scene.entry(m.id)
        assert e.checker.static_contacts() == []
        free = w.collision_free_batch(m.id, e.bound.random_q(np.random.default_rng(1), 200))
        assert free.mean() > 0.25


def test_obstacles_share_one_point_sized_visual_shape() -> None:
    """No obstacle body, nor the mirror's compound of small ones, has a visual made from its collision shape
    (PyBullet tessellates spheres and cylinders for it, which costs more than the body): each has the
    client's one point-sized box, and its collision shape is the obstacle's."""
    import pybullet as pb

    with World() as w:
        w.load_scene(SCENES / "obstacles-66.json")
        bullets = [(w.scene.bullet, [b for b, _ in w.scene.obstacle_bodies()])]
        mirror = w.queries.mirror()
        bullets.append((mirror.bullet, [b for b in range(pb.getNumBodies(physicsClientId=mirror.bullet.cid))
                                        if b not in mirror.bodies.values()]))
        for bullet, bodies in bullets:
            assert len(bodies) > 1
            for body in bodies:
                visual = pb.getVisualShapeData(body, physicsClientId=bullet.cid)
                assert [(v[2], tuple(v[3])) for v in visual] == [(pb.GEOM_BOX, (2e-6,) * 3)]
            types = {c[2] for b in bodies
                     for c in pb.getCollisionShapeData(b, -1, physicsClientId=bullet.cid)}
            assert {pb.GEOM_SPHERE, pb.GEOM_CYLINDER} <= types


def test_table_scene_and_round_trip() -> None:
    """table.json loads a kuka and obstacles; scene_spec() rebuilds an identical world."""
    with World() as w:
        out = w.load_scene(SCENES / "table.json")
        assert out == {"robots": ["kuka"], "obstacles": ["table", "box", "can"], "objects": [],
                       "conveyors": [], "sensors": []}
        w.set_joint_positions("kuka", [0.2, 0.5, 0, -1.0, 0, 0.4, 0])
        spec = w.scene_spec()
        json.dumps(spec)
        with World() as w2:
            w2.load_scene(spec)
            assert w2.list() == w.list()
            assert np.allclose(w2.get_joint_positions("kuka"), w.get_joint_positions("kuka"))
            assert w2.fk("kuka") == w.fk("kuka")


def test_relative_mesh_obstacle_resolved_against_scene_folder(tmp_path) -> None:
    """A mesh obstacle's relative file is found next to the scene file; a missing one is FileNotFound."""
    (tmp_path / "parts").mkdir()
    (tmp_path / "parts" / "cube.obj").write_bytes((MODELS / "meshes" / "cube.obj").read_bytes())
    doc = {
        "version": 1,
        "obstacles": [
            {"name": "m", "shape": {"type": "mesh", "file": "parts/cube.obj"}, "position": [0.5, 0, 0.5]}
        ],
    }
    (tmp_path / "s.json").write_text(json.dumps(doc))
    with World() as w:
        w.load_scene(tmp_path / "s.json")
        assert w.list()["obstacles"][0]["shape"]["file"] == str(tmp_path / "parts" / "cube.obj")
        doc["obstacles"][0]["shape"]["file"] = "parts/none.obj"
        doc["obstacles"][0]["name"] = "n"
        (tmp_path / "t.json").write_text(json.dumps(doc))
        with pytest.raises(FileNotFound):
            w.load_scene(tmp_path / "t.json")
        assert [o["name"] for o in w.list()["obstacles"]] == ["m"]


def test_a_batch_of_labels_with_an_ascii_stl_obstacle_uses_the_converted_mesh() -> None:
    """The batch labelling's mirror world builds a mesh obstacle from the file the world converted (an
    ASCII STL crashed PyBullet there: the process died), and labels as the world's own checks do."""
    with World() as w:
        w.load_robot("kuka_iiwa/model.urdf", robot_id="r")
        w.add_obstacle({"name": "part", "shape": {"type": "mesh", "file": str(MODELS / "meshes" / "cube.stl"),
                                                  "scale": [0.3, 0.3, 0.3]}, "position": [0.0, -0.3, 0.4]})
        lo, hi = w.robot_model("r").limits()
        qs = np.random.default_rng(0).uniform(lo, hi, (300, 7))
        labels = w.collision_free_batch("r", qs)
        assert labels.tolist() == [w.check_collision("r", q).collision_free for q in qs]
        assert 0 < labels.sum() < len(qs)
