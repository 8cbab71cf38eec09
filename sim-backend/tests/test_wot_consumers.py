"""A W3C WoT consumer other than node-wot drives the twin from the served TD as it is: wotpy 0.18 (the
Python WoT runtime) reads every property, invokes every action and receives the collision event, with no
patch to the TD or to wotpy. Real CLI (`node`), backend and servient, over HTTP."""

from __future__ import annotations

import asyncio
import json
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest
from served_twin import served_twin
from wotpy.wot.servient import Servient

HOME = {f"lbr_iiwa_joint_{i}": 0.0 for i in range(1, 8)}


@pytest.fixture(scope="module")
def twin_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A generated KUKA twin served by `robwot serve` on a free port; yields the TD URL."""
    with served_twin(tmp_path_factory.mktemp("wot") / "kuka") as url:
        yield url


async def _drive(url: str) -> dict[str, Any]:
    """Everything a consumer does, through wotpy's consume_from_url and nothing else."""
    servient = Servient(catalogue_port=None)
    wot = await servient.start()
    seen: dict[str, Any] = {}
    try:
        thing = await wot.consume_from_url(url)
        seen["properties"] = {n: await thing.read_property(n) for n in thing.properties}
        seen["validate_joints"] = await thing.invoke_action("validateJointPosition", {"joints": HOME})
        seen["validate_pose"] = await thing.invoke_action("validateCartesianPosition",
                                                          {"x": 0.4, "y": 0.1, "z": 0.6})
        seen["move_pose"] = await thing.invoke_action("moveToCartesianPosition",
                                                      {"x": 0.4, "y": 0.1, "z": 0.6})
        seen["move_joints"] = await thing.invoke_action("moveToJointPosition", {"joints": HOME})
        seen["stop"] = await thing.invoke_action("stop")
        box = {"type": "box", "size": [0.1, 0.1, 0.1]}
        seen["add"] = await thing.invoke_action("addObstacle",
                                                {"name": "w", "shape": box, "position": [2, 2, 0]})
        seen["move_obstacle"] = await thing.invoke_action("moveObstacle",
                                                          {"name": "w", "position": [2, 3, 0]})
        seen["remove"] = await thing.invoke_action("removeObstacle", {"name": "w"})
        pairs = [{"real": {"x": x, "y": y, "z": z}, "virtual": {"x": x, "y": y, "z": z}}
                 for x, y, z in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))]
        seen["calibrate"] = await thing.invoke_action("calibrate", {"pairs": pairs, "withScale": False})

        events: list[Any] = []
        sub = thing.on_event("collision").subscribe(events.append)
        await asyncio.sleep(1.0)  # the long-poll subscription is open
        target = dict(HOME, lbr_iiwa_joint_2=1.2, lbr_iiwa_joint_4=-0.4, lbr_iiwa_joint_6=0.4)
        slow = {"joints": target, "speed": 0.05}
        move = asyncio.ensure_future(thing.invoke_action("moveToJointPosition", slow))
        await asyncio.sleep(1.5)
        intruder = {"name": "intruder", "shape": {"type": "box", "size": [0.2, 0.6, 0.2]},
                    "position": [0.55, 0, 0.75]}
        await thing.invoke_action("addObstacle", intruder)
        seen["collision_move"] = await move
        for _ in range(50):
            if events:
                break
            await asyncio.sleep(0.1)
        sub.dispose()
        seen["events"] = events
        seen["status"] = await thing.read_property("motionStatus")
    finally:
        await servient.shutdown()
    return seen


def test_wotpy_consumes_the_served_td_unmodified(twin_url: str) -> None:
    """Every property read, every action invoked, the collision event received — by wotpy as it is."""
    td = json.load(urllib.request.urlopen(twin_url))
    seen = asyncio.run(_drive(twin_url))
    assert set(seen["properties"]) == set(td["properties"])
    assert seen["properties"]["motionStatus"]["state"] in ("idle", "stopped")
    assert set(seen["properties"]["getJointPosition"]) == set(HOME)
    assert seen["validate_joints"]["valid"] is True and seen["validate_pose"]["valid"] is True
    assert seen["move_pose"]["status"] == "reached" and seen["move_joints"]["status"] == "reached"
    assert seen["stop"] == {"stopped": False, "simulation": {"ok": True}}
    assert seen["add"]["name"] == "w" and seen["move_obstacle"]["position"] == [2, 3, 0]
    assert seen["calibrate"]["scale"] == 1 and seen["calibrate"]["rms"] < 1e-9
    assert seen["collision_move"]["status"] == "collision"
    assert seen["events"], "no collision event reached wotpy"
    event = seen["events"][0]
    data = getattr(event, "data", event)
    assert "intruder" in {data["pair"]["a"]["body"], data["pair"]["b"]["body"]}
    assert seen["status"]["state"] == "collision"
