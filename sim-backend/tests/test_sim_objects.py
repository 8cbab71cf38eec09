"""Objects: bodies that settle onto what is below them, that robots collide with as with obstacles (every
verdict names them), and that scene files and requests may add, move and remove; bad input refused whole."""

from __future__ import annotations

import json
from typing import Any

import pytest
from rpc_backend import RpcClient
from simhelp import KUKA, SCENES

from robwot_sim.errors import InvalidParams, Overlap, SceneError, UnknownObject
from robwot_sim.limits import DEFAULT_MASS, MAX_OBJECTS
from robwot_sim.sim.planner import plan_pose
from robwot_sim.sim.world import World

CUBE = {"type": "box", "size": [0.05, 0.05, 0.05]}
TABLE = {"name": "table", "shape": {"type": "box", "size": [0.6, 0.6, 0.4]}, "position": [2.0, 0.0, 0.2]}


def cube(name: str, position: list[float], **more: Any) -> dict[str, Any]:
    return {"name": name, "shape": CUBE, "position": position, **more}


def test_an_object_dropped_above_a_table_rests_on_its_top() -> None:
    """A cube let go 0.4 m above a table's top comes to rest on it, upright, with the default mass."""
    with World() as w:
        w.add_obstacle(TABLE)
        out = w.add_object(cube("c", [2.1, 0.05, 0.8], color=[1, 0, 0]))
        assert out["position"] == pytest.approx([2.1, 0.05, 0.425], abs=2e-3)
        assert out["orientation"] == pytest.approx([0, 0, 0, 1], abs=1e-3)
        assert out["mass"] == DEFAULT_MASS and out["color"] == [1, 0, 0]
        assert w.list()["objects"] == [out] and [o["name"] for o in w.list()["obstacles"]] == ["table"]


@pytest.mark.parametrize(("shape", "z"), [
    ({"type": "sphere", "radius": 0.04}, 0.04),
    ({"type": "cylinder", "radius": 0.03, "length": 0.1}, 0.05),
    (CUBE, 0.025),
])
def test_an_object_with_nothing_below_rests_on_the_floor(shape: dict[str, Any], z: float) -> None:
    """With nothing under it an object falls onto the floor plane z = 0."""
    with World() as w:
        w.add_obstacle(TABLE)  # beside its fall, not under it
        out = w.add_object({"name": "o", "shape": shape, "position": [-1.0, 1.0, 0.6], "mass": 0.5})
        assert out["position"] == pytest.approx([-1.0, 1.0, z], abs=2e-3)


def test_settling_is_deterministic() -> None:
    """The same scene gives the same poses, to the last bit, in two worlds."""
    doc = {"version": 1, "obstacles": [TABLE],
           "objects": [cube("a", [2.0, 0.0, 0.6]), cube("b", [2.01, 0.0, 0.7], rpy=[0.3, 0.2, 0.1]),
                       {"name": "ball", "shape": {"type": "sphere", "radius": 0.03}, "position": [0, 1, 1]}]}
    poses = []
    for _ in range(2):
        with World() as w:
            assert w.load_scene(doc)["objects"] == ["a", "b", "ball"]
            poses.append(json.dumps(w.list()["objects"]))
    assert poses[0] == poses[1]
    stacked = {o["name"]: o for o in json.loads(poses[0])}
    assert stacked["a"]["position"][2] == pytest.approx(0.425, abs=2e-3)
    assert stacked["b"]["position"][2] > 0.44  # on the first cube, settled together


def test_a_move_into_an_object_is_refused_naming_it() -> None:
    """A cube resting on a stand is to the planner what an obstacle is: a pose inside it is refused
    naming it, a sweep through it names it, and a collision check at a touching state names it."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle({"name": "stand", "shape": {"type": "box", "size": [0.3, 0.3, 0.4]},
                        "position": [0.45, 0.1, 0.2]})
        block = w.add_object({"name": "block", "shape": {"type": "box", "size": [0.3, 0.3, 0.3]},
                              "position": [0.45, 0.1, 0.6]})
        assert block["position"][2] == pytest.approx(0.55, abs=2e-3)
        plan = plan_pose(w, m.id, (0.45, 0.1, 0.55), None, 1.0, 1 / 240)
        assert not plan.valid and "block" in plan.reasons[0]
        assert any("block" in (c["a"]["body"], c["b"]["body"]) for c in plan.checks["path"]["contacts"])
        w.set_joint_positions(m.id, [-1.5, 1.0, 0, 0, 0, 0, 0])
        w.add_object({"name": "post", "shape": {"type": "cylinder", "radius": 0.05, "length": 1.0},
                      "position": [0.6, -0.6, 0.5]})
        rep = w.check_path(m.id, [0.0, 1.0, 0, 0, 0, 0, 0], speed=0.5)
        assert rep.first_collision is not None
        assert any(c.b.body == "post" for c in rep.first_collision.contacts)
        assert not w.collision_free_batch(m.id, [rep.first_collision.positions])[0]


def test_an_object_placed_into_a_body_is_refused_naming_both_and_nothing_changes() -> None:
    """Placed into an obstacle, a robot or the floor, or moved into one: E_OVERLAP naming both bodies; the
    world is as before (a refused move leaves the object where it rested)."""
    with World() as w:
        m = w.load_robot(KUKA)
        w.add_obstacle(TABLE)
        with pytest.raises(Overlap) as ei:
            w.add_object(cube("in-table", [2.0, 0.0, 0.3]))
        assert ei.value.data["object"] == "in-table" and ei.value.data["body"] == "table"
        with pytest.raises(Overlap) as ei:
            w.add_object(cube("in-robot", [0.0, 0.0, 0.3]))
        assert ei.value.data["body"] == m.id
        with pytest.raises(Overlap, match="floor"):
            w.add_object(cube("under", [1.0, 1.0, -0.1]))
        assert w.list()["objects"] == []
        rested = w.add_object(cube("c", [2.0, 0.0, 0.5]))
        with pytest.raises(Overlap, match="'table'"):
            w.move_object("c", [2.0, 0.1, 0.2])
        assert w.list()["objects"] == [rested]
        moved = w.move_object("c", [1.0, 1.0, 0.3], [0, 0, 0.3826834, 0.9238795])
        assert moved["position"] == pytest.approx([1.0, 1.0, 0.025], abs=2e-3)


def test_objects_and_obstacles_are_separate_kinds_of_one_namespace() -> None:
    """obstacle.* does not touch objects (nor the reverse), names are shared, removing frees the name."""
    with World() as w:
        w.add_obstacle(TABLE)
        w.add_object(cube("c", [0, 0, 0.1]))
        with pytest.raises(UnknownObject):
            w.remove_obstacle("c")
        with pytest.raises(UnknownObject):
            w.move_object("table", [0, 0, 1])
        with pytest.raises(Exception, match="already used"):
            w.add_object(cube("table", [1, 1, 0.1]))
        w.remove_object("c")
        assert w.list()["objects"] == []
        w.add_obstacle({**TABLE, "name": "c", "position": [5, 5, 0.2]})


def test_a_scene_with_a_bad_object_loads_nothing() -> None:
    """All or nothing: a scene whose second object lies inside its first adds no obstacle or object."""
    doc = {"version": 1, "obstacles": [TABLE], "objects": [cube("a", [0, 0, 0.5]), cube("b", [0, 0.01, 0.5])]}
    with World() as w:
        with pytest.raises(Overlap) as ei:
            w.load_scene(doc)
        assert {ei.value.data["object"], ei.value.data["body"]} == {"a", "b"}
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


@pytest.mark.parametrize(("objects", "pointer", "words"), [
    ([cube("table", [0, 0, 1])], "/objects/0/name", "duplicate name 'table'"),
    ([cube("a", [0, 0, 1], size=3)], "/objects/0", "size"),
    ([cube("a", [0, 0, 1], mass=0)], "/objects/0/mass", "0"),
    ([cube("a", [0, 0, 1], rpy=[0, 0, 0], orientation=[0, 0, 0, 1])], "/objects/0", "not"),
    ([cube("a", [0, 0, 1], orientation=[0, 0, 0, 0])], "/objects/0/orientation", "zero norm"),
    ([cube(f"o{i}", [0, 0, i]) for i in range(10_000)], "/objects", f"more than the limit of {MAX_OBJECTS}"),
])
def test_bad_objects_in_a_scene_file_are_refused_with_file_and_place(
        tmp_path, objects: list[dict[str, Any]], pointer: str, words: str) -> None:
    """Duplicate names (with obstacles too), unknown fields, a non-positive mass, both orientations, a
    zero quaternion, 10^4 objects: E_SCENE naming the file and the place, nothing loaded."""
    f = tmp_path / "scene.json"
    f.write_text(json.dumps({"version": 1, "obstacles": [TABLE], "objects": objects}))
    with World() as w:
        with pytest.raises(SceneError) as ei:
            w.load_scene(f)
        assert ei.value.data["file"] == str(f) and ei.value.data["path"] == pointer
        assert words in ei.value.message and len(ei.value.message) < 500
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}


def test_the_world_holds_at_most_the_contracts_number_of_objects(monkeypatch: pytest.MonkeyPatch) -> None:
    """object.add past the limit is refused naming it; the world keeps what it had."""
    from robwot_sim.sim import planning_scene

    monkeypatch.setattr(planning_scene, "MAX_OBJECTS", 2)
    with World() as w:
        w.add_object(cube("a", [0, 0, 0.1]))
        w.add_object(cube("b", [1, 0, 0.1]))
        with pytest.raises(InvalidParams, match="at most 2 objects"):
            w.add_object(cube("c", [2, 0, 0.1]))
        assert [o["name"] for o in w.list()["objects"]] == ["a", "b"]


def test_object_methods_over_the_wire(client: RpcClient) -> None:
    """object.add / move / remove and world.list through the contract (results checked against it)."""
    client.call("obstacle.add", TABLE)
    cup = {"type": "cylinder", "radius": 0.03, "length": 0.08}
    out = client.call("object.add", {"name": "cup", "shape": cup, "position": [2.0, 0.1, 0.7],
                                     "color": [0, 0, 1]})
    assert out["mass"] == DEFAULT_MASS and out["position"][2] == pytest.approx(0.44, abs=2e-3)
    assert client.call("world.list")["objects"] == [out]
    err = client.error("object.add", {"name": "cup2", "shape": CUBE, "position": [2.0, 0.0, 0.2]})
    assert err.data["code"] == "E_OVERLAP" and err.data["body"] == "table"
    moved = client.call("object.move", {"name": "cup", "position": [0.0, 2.0, 0.5]})
    assert moved["position"] == pytest.approx([0.0, 2.0, 0.04], abs=2e-3)
    assert client.error("object.remove", {"name": "table"}).data["code"] == "E_UNKNOWN_OBJECT"
    assert client.call("object.remove", {"name": "cup"}) == {}
    assert client.call("world.list")["objects"] == []


def test_the_readme_objects_snippet_is_the_example_scene_and_loads() -> None:
    """README "Objects" shows examples/scenes/objects.json (its name and description aside), which loads:
    the cube and the cup rest on the table, the crate on the floor."""
    readme = (SCENES.parents[1] / "README.md").read_text(encoding="utf-8")
    section = readme[readme.index("### Objects\n"):]
    start = section.index("```json\n") + len("```json\n")
    snippet = json.loads(section[start:section.index("\n```", start)])
    example = json.loads((SCENES / "objects.json").read_text(encoding="utf-8"))
    assert snippet == {k: v for k, v in example.items() if k not in ("name", "description")}
    with World() as w:
        w.load_robot(KUKA)
        w.load_scene(SCENES / "objects.json")
        z = {o["name"]: o["position"][2] for o in w.list()["objects"]}
        assert z == pytest.approx({"cube": 0.325, "cup": 0.35, "crate": 0.2}, abs=2e-3)
