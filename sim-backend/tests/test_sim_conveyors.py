"""Conveyors and sensors (the cell, `sim/cell.py`) with the real scene and PyBullet: a running belt carries
the objects resting on it to its end stop, or off its end onto the floor; presence and colour sensors see
them; bad input is refused whole; the scene document round trip keeps them; the methods over the wire."""

from __future__ import annotations

import json
from typing import Any

import pytest
from rpc_backend import RpcClient
from simhelp import SCENES

from robwot_sim.errors import InvalidParams, NameTaken, Overlap, SceneError, UnknownObject
from robwot_sim.limits import BELT_SUB_STEP, DEFAULT_BELT_SPEED, DEFAULT_SENSOR_COLOR, MAX_CELL_DT
from robwot_sim.sim.world import World

CUBE = {"type": "box", "size": [0.04, 0.04, 0.04]}
#: a level belt from x = 0.7 to 1.3 m, its top face at z = 0.225 m
BELT = {"name": "belt", "size": [0.6, 0.1, 0.05], "position": [1.0, 0.0, 0.2]}
END = 1.3
BEAM = {"name": "beam", "kind": "presence", "size": [0.004, 0.2, 0.01], "position": [1.27, 0.0, 0.235]}


def scene(belt: dict[str, Any] | None = None, **more: Any) -> dict[str, Any]:
    """A document: the belt (overridden by ``belt``), a red cube let go above its x = 0.8 m, ``more``."""
    cube = {"name": "cube", "shape": CUBE, "position": [0.8, 0.0, 0.3], "color": [1, 0, 0]}
    return {"version": 1, "conveyors": [{**BELT, **(belt or {})}], "objects": [cube], **more}


def cube_of(w: World) -> dict[str, Any]:
    return next(o for o in w.list()["objects"] if o["name"] == "cube")


def run(w: World, seconds: float, dt: float = 0.5) -> list[dict[str, Any]]:
    """Every event of advancing ``seconds`` in steps of ``dt``."""
    events = []
    for _ in range(round(seconds / dt)):
        events += w.cell.advance(dt)["events"]
    return events


def test_a_cube_on_a_running_belt_stops_at_the_end_stop_reported_once() -> None:
    """The cube arrives at the end after (distance to the end) / speed seconds, within a sub-step, stops
    with its edge flush with the end, and `atEnd` is said once; the belt's speed and end stop default."""
    with World() as w:
        w.load_scene(scene())
        start = cube_of(w)["position"]
        assert start[2] == pytest.approx(0.245, abs=2e-3)
        out = w.cell.set_conveyor("belt", "forward")
        assert out["changed"] and out["conveyor"]["speed"] == DEFAULT_BELT_SPEED
        assert out["conveyor"]["endStop"] is True
        expected = (END - (start[0] + 0.02)) / DEFAULT_BELT_SPEED
        events = run(w, 12.0)
        arrivals = [e for e in events if e["type"] == "atEnd"]
        assert [{**e, "time": 0} for e in arrivals] == [
            {"type": "atEnd", "conveyor": "belt", "object": "cube", "time": 0}]
        assert arrivals[0]["time"] == pytest.approx(expected, abs=BELT_SUB_STEP / DEFAULT_BELT_SPEED + 1e-9)
        rest = cube_of(w)
        assert rest["position"][0] + 0.02 == pytest.approx(END, abs=1e-4)
        assert rest["position"][1:] == pytest.approx(start[1:], abs=1e-9)  # carried along x only
        quiet = w.cell.advance(1.0)  # at the end stop: not moved, not said again
        assert quiet["moved"] == [] and quiet["events"] == [] and quiet["time"] == pytest.approx(13.0)
        assert w.cell.listing()["time"] == pytest.approx(13.0)


def test_a_backward_belt_carries_to_its_other_end() -> None:
    with World() as w:
        w.load_scene(scene({"state": "backward", "speed": 0.1}))
        start = cube_of(w)["position"][0]
        events = run(w, 2.0)
        assert [e["type"] for e in events] == ["atEnd"]
        assert events[0]["time"] == pytest.approx((start - 0.02 - 0.7) / 0.1, abs=0.05 + 1e-9)
        assert cube_of(w)["position"][0] - 0.02 == pytest.approx(0.7, abs=1e-4)


def test_without_an_end_stop_the_cube_falls_off_and_rests_on_the_floor() -> None:
    with World() as w:
        w.load_scene(scene({"endStop": False, "state": "forward", "speed": 0.2}))
        events = run(w, 4.0)
        fell = [e for e in events if e["type"] == "fell"]
        assert len(fell) == 1 and not [e for e in events if e["type"] == "atEnd"]
        rest = cube_of(w)
        assert fell[0]["position"] == rest["position"]
        assert rest["position"][2] == pytest.approx(0.02, abs=2e-3)  # half its size: on the floor
        assert rest["position"][0] - 0.02 >= END  # clear of the belt's end
        assert run(w, 1.0) == []  # the belt no longer carries it


def test_a_presence_sensor_fires_once_as_the_cube_enters_and_a_colour_sensor_reads_its_rgb() -> None:
    eye = {"name": "eye", "kind": "color", "size": [0.05, 0.05, 0.05], "position": [1.26, 0.0, 0.25]}
    grey = {"name": "grey", "shape": CUBE, "position": [2.0, 0.0, 0.1]}
    look = {"name": "look", "kind": "color", "size": [0.1, 0.1, 0.1], "position": [2.0, 0.0, 0.05]}
    with World() as w:
        doc = scene({"state": "forward", "speed": 0.1}, sensors=[BEAM, eye, look])
        w.load_scene({**doc, "objects": [*doc["objects"], grey]})
        before = {s["name"]: s["reading"] for s in w.cell.listing()["sensors"]}
        assert before["beam"] == {"name": "beam", "kind": "presence", "objectPresence": False, "object": None}
        assert before["eye"]["color"] is None
        assert before["look"]["color"] == list(DEFAULT_SENSOR_COLOR)  # an object without a colour: grey
        events = run(w, 6.0)
        detected = [e for e in events if e["type"] == "detectedObject"]
        assert [(e["sensor"], e["object"]) for e in detected] == [("eye", "cube"), ("beam", "cube")]
        # the beam at x = 1.27 m: the cube's leading edge reaches it (1.27 - 0.002 m) ...
        lead = 0.8 + 0.02
        assert detected[1]["time"] == pytest.approx((1.268 - lead) / 0.1, abs=0.05 + 1e-3)
        readings = {s["name"]: s for s in w.cell.advance(0.1)["sensors"]}
        assert readings["beam"]["objectPresence"] and readings["beam"]["object"] == "cube"
        assert readings["eye"]["color"] == [255, 0, 0]
        assert all(isinstance(c, int) for c in readings["eye"]["color"])


def test_starting_a_running_belt_again_is_a_defined_outcome() -> None:
    with World() as w:
        w.load_scene(scene())
        assert w.cell.set_conveyor("belt", "forward", 0.1)["changed"] is True
        again = w.cell.set_conveyor("belt", "forward")
        assert again["changed"] is False
        assert (again["conveyor"]["state"], again["conveyor"]["speed"]) == ("forward", 0.1)
        assert w.cell.set_conveyor("belt", "forward", 0.2)["changed"] is True
        assert w.cell.set_conveyor("belt", "stopped")["changed"] is True
        assert w.cell.set_conveyor("belt", "stopped")["changed"] is False
        assert w.cell.advance(1.0)["moved"] == []


@pytest.mark.parametrize(("call", "param"), [
    (lambda w: w.cell.set_conveyor("belt", "sideways"), "state"),
    (lambda w: w.cell.set_conveyor("belt", "forward", 0.0), "speed"),
    (lambda w: w.cell.set_conveyor("belt", "forward", 5.0), "speed"),
    (lambda w: w.cell.set_conveyor("belt", "forward", True), "speed"),
    (lambda w: w.cell.advance(0.0), "dt"),
    (lambda w: w.cell.advance(MAX_CELL_DT + 0.5), "dt"),
])
def test_bad_params_are_refused_naming_them_and_nothing_changes(call: Any, param: str) -> None:
    with World() as w:
        w.load_scene(scene())
        before, version = w.cell.listing(), w.scene.version
        with pytest.raises(InvalidParams) as err:
            call(w)
        assert err.value.data["param"] == param
        assert w.cell.listing() == before and w.scene.version == version


def test_unknown_names_are_refused_with_the_known_ones() -> None:
    with World() as w:
        w.load_scene(scene())
        w.add_obstacle({"name": "table", "shape": CUBE, "position": [3, 0, 0.02]})
        for name in ("nope", "table", "cube"):
            with pytest.raises(UnknownObject) as err:
                w.cell.set_conveyor(name, "forward")
            assert err.value.code == "E_UNKNOWN_OBJECT" and err.value.data["available"] == ["belt"]
        assert w.cell.listing()["conveyors"][0]["state"] == "stopped"


def test_bad_scene_documents_are_refused_whole() -> None:
    with World() as w:
        with pytest.raises(SceneError) as err:
            w.load_scene(scene({"size": [0.6, -0.1, 0.05]}))
        assert err.value.data["path"].startswith("/conveyors/0/size")
        with pytest.raises(SceneError, match="duplicate name 'belt'"):
            w.load_scene(scene(obstacles=[{"name": "belt", "shape": CUBE, "position": [3, 0, 0]}]))
        with pytest.raises(SceneError, match="duplicate name 'beam'"):
            w.load_scene(scene(sensors=[BEAM, BEAM]))
        with pytest.raises(SceneError) as err:
            w.load_scene(scene(sensors=[{**BEAM, "kind": "sonar"}]))
        assert err.value.data["path"].startswith("/sensors/0")
        assert w.list() == {"robots": [], "obstacles": [], "objects": [], "conveyors": [], "sensors": []}
        w.load_scene(scene(sensors=[BEAM]))
        other = {"version": 1, "objects": [{"name": "ball", "shape": {"type": "sphere", "radius": 0.02},
                                            "position": [3, 0, 0.1]}], "sensors": [BEAM]}
        with pytest.raises(NameTaken):  # a sensor of that name already: nothing of the document added
            w.load_scene(other)
        assert [o["name"] for o in w.list()["objects"]] == ["cube"]


def test_the_world_holds_at_most_the_contracts_number_of_conveyors_and_sensors(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("robwot_sim.sim.cell.MAX_SENSORS", 1)
    with World() as w:
        w.load_scene(scene(sensors=[BEAM]))
        more = {"version": 1, "sensors": [{**BEAM, "name": "beam2"}],
                "obstacles": [{"name": "wall", "shape": CUBE, "position": [3, 0, 0.02]}]}
        with pytest.raises(InvalidParams, match="at most 1 sensors") as err:
            w.load_scene(more)
        assert err.value.data["param"] == "sensors"
        assert [s["name"] for s in w.list()["sensors"]] == ["beam"] and w.list()["obstacles"] == []


def test_the_belt_is_an_obstacle_of_the_conveyors_name() -> None:
    """Bodies collide with the belt (named as the conveyor); listed as a conveyor, not as an obstacle;
    removing that obstacle removes the conveyor."""
    with World() as w:
        w.load_scene(scene())
        assert w.list()["obstacles"] == [] and [c["name"] for c in w.list()["conveyors"]] == ["belt"]
        with pytest.raises(Overlap, match="belt"):
            w.add_object({"name": "into", "shape": CUBE, "position": [1.0, 0.0, 0.21]})
        w.remove_obstacle("belt")
        assert w.cell.listing()["conveyors"] == [] and w.list()["conveyors"] == []
        w.remove_object("cube")
        assert w.cell.advance(0.5)["moved"] == []


def test_objects_queue_behind_one_stopped_at_the_end() -> None:
    with World() as w:
        doc = scene({"state": "forward", "speed": 0.2})
        second = {"name": "second", "shape": CUBE, "position": [0.75, 0.0, 0.3]}
        w.load_scene({**doc, "objects": [*doc["objects"], second]})
        run(w, 4.0)
        x = {o["name"]: o["position"][0] for o in w.list()["objects"]}
        assert x["cube"] == pytest.approx(END - 0.02, abs=1e-4)
        assert x["second"] == pytest.approx(END - 0.06, abs=1e-4)  # flush behind the first


def test_an_object_removed_between_advances_is_no_trouble() -> None:
    with World() as w:
        w.load_scene(scene({"state": "forward"}, sensors=[BEAM]))
        w.cell.advance(1.0)
        w.remove_object("cube")
        out = w.cell.advance(1.0)
        assert out["moved"] == [] and out["sensors"][0]["objectPresence"] is False


def test_the_scene_document_round_trip_keeps_conveyors_and_sensors() -> None:
    eye = {"name": "eye", "kind": "color", "size": [0.05, 0.05, 0.05], "position": [1.2, 0.0, 0.25],
           "rpy": [0.0, 0.0, 0.3]}
    with World() as w:
        belt = {"rpy": [0.0, 0.0, 0.2], "endStop": False, "color": [0, 0, 1]}
        w.load_scene(scene(belt, sensors=[BEAM, eye]))
        w.cell.set_conveyor("belt", "backward", 0.3)
        spec = w.scene_spec()
        listed = w.cell.listing()
    assert [o["name"] for o in spec["obstacles"]] == ["cube"]  # the belt only as the conveyor
    with World() as again:
        loaded = again.load_scene(json.loads(json.dumps(spec)))
        assert loaded["conveyors"] == ["belt"] and loaded["sensors"] == ["beam", "eye"]
        assert again.cell.listing() == listed


def test_the_example_conveyor_scene_loads_and_runs() -> None:
    """examples/scenes/conveyor.json: the cube runs to the end, passing the colour sensor, then the beam."""
    with World() as w:
        loaded = w.load_scene(SCENES / "conveyor.json")
        assert loaded == {"robots": [], "obstacles": [], "objects": ["cube"], "conveyors": ["belt"],
                          "sensors": ["beam", "eye"]}
        w.cell.set_conveyor("belt", "forward")
        events = [e for e in run(w, 14.0, 1.0) if e["type"] in ("detectedObject", "atEnd")]
        assert [(e["type"], e.get("sensor")) for e in events] == [
            ("detectedObject", "eye"), ("detectedObject", "beam"), ("atEnd", None)]
        assert cube_of(w)["position"][1] == pytest.approx(-0.1 - 0.02, abs=1e-4)


def test_cell_methods_over_the_wire(client: RpcClient) -> None:
    """conveyor.set, cell.advance, cell.list and world.list through the contract (results checked)."""
    client.call("world.loadScene", {"scene": scene(sensors=[BEAM])})
    listed = client.call("world.list")
    assert [c["name"] for c in listed["conveyors"]] == ["belt"] and listed["obstacles"] == []
    set_ = client.call("conveyor.set", {"name": "belt", "state": "forward", "speed": 0.5})
    assert set_["changed"] is True and set_["conveyor"]["state"] == "forward"
    assert client.call("conveyor.set", {"name": "belt", "state": "forward"})["changed"] is False
    out = client.call("cell.advance", {"dt": 1.0})
    assert out["time"] == pytest.approx(1.0) and [o["name"] for o in out["moved"]] == ["cube"]
    assert [e["type"] for e in out["events"]] == ["detectedObject", "atEnd"]
    assert out["sensors"][0]["objectPresence"] is True
    cell = client.call("cell.list")
    assert cell["time"] == pytest.approx(1.0) and cell["sensors"][0]["reading"]["object"] == "cube"
    err = client.error("conveyor.set", {"name": "nope", "state": "forward"})
    assert err.data["code"] == "E_UNKNOWN_OBJECT" and err.data["available"] == ["belt"]
    for params, param in (({"name": "belt", "state": "up"}, "state"),
                          ({"name": "belt", "state": "forward", "speed": 3}, "speed")):
        assert client.error("conveyor.set", params).data["param"] == param
    assert client.error("cell.advance", {"dt": 0}).data["param"] == "dt"
    assert client.error("cell.advance", {"dt": 2}).data["param"] == "dt"
    assert client.call("cell.list") == cell
