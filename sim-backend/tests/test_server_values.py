"""Hostile values over the real WebSocket: every number a param's type allows is either handled or refused
by name (-32602), never an internal error, never a world holding a body at 1e308 or a zero quaternion."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest
from rpc_backend import RpcClient

from robwot_sim.rpc.protocol import MAX_DEPTH

BOX = {"type": "box", "size": [0.1, 0.1, 0.1]}


def _nested(depth: int) -> str:
    """A ping whose params nest `depth` levels in all (the request object is level 1)."""
    inner = "[" * (depth - 2) + "]" * (depth - 2)
    return '{"jsonrpc":"2.0","id":7,"method":"ping","params":{"x":' + inner + "}}"


Case = Callable[[RpcClient], Any]

REFUSED: list[tuple[str, int, str, Case, dict[str, Any]]] = [
    ("frame nested 20,000 deep", -32600, "E_TOO_DEEP", lambda c: c.raw(_nested(20_000)),
     {"limit": MAX_DEPTH}),
    ("frame nested 900 deep", -32600, "E_TOO_DEEP", lambda c: c.raw(_nested(900)),
     {"limit": MAX_DEPTH}),
    ("frame nested one level too deep", -32600, "E_TOO_DEEP", lambda c: c.raw(_nested(MAX_DEPTH + 1)), {}),
    ("obstacle moved to 1e308 m", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("obstacle.move", {"name": "box", "position": [1e308, 0, 0]}),
     {"param": "position[0]"}),
    ("obstacle turned by 1e308 rad", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("obstacle.move", {"name": "box", "position": [0.6, 0, 0.3], "rpy": [0, 1e308, 0]}),
     {"param": "rpy[1]"}),
    ("robot based at 1e308 m", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "k2",
                                      "basePosition": [0, 0, 1e308]}),
     {"param": "basePosition[2]"}),
    ("IK target at 1e308 m", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("robot.ik", {"robot": "kuka", "position": [1e308, 0, 0]}), {"param": "position[0]"}),
    ("quaternion of norm 1e-7", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("obstacle.add", {"name": "b", "shape": BOX, "position": [2, 0, 0],
                                        "orientation": [1e-7, 0, 0, 0]}), {"param": "orientation"}),
    ("path time step of 1e-300 s", -32602, "E_INVALID_PARAMS",
     lambda c: c.error("robot.checkPath", {"robot": "kuka", "target": [0.1] * 7, "dt": 1e-300}),
     {"param": "dt", "expected": "a finite number >= 0.0001 and <= 0.1"}),
]


@pytest.fixture
def world(client: RpcClient) -> RpcClient:
    """The KUKA plus one box obstacle."""
    client.call("obstacle.add", {"name": "box", "shape": BOX, "position": [0.6, 0.0, 0.3]})
    return client


@pytest.mark.parametrize(("label", "code", "data_code", "case", "fields"), REFUSED,
                         ids=[c[0] for c in REFUSED])
def test_refused_by_name_world_unchanged(world: RpcClient, label: str, code: int, data_code: str, case: Case,
                                         fields: dict[str, Any]) -> None:
    """The value is refused with its code and param; the world is unchanged; the server answers."""
    before = world.call("world.list")
    outcome = case(world)
    error = outcome["error"] if isinstance(outcome, dict) else outcome.error
    assert (error["code"], error["data"]["code"]) == (code, data_code), error
    for key, value in fields.items():
        assert error["data"][key] == value, error
    assert len(error["message"]) < 300
    assert world.call("world.list") == before
    assert world.call("ping")["version"]


def test_deepest_allowed_frame_is_served(client: RpcClient) -> None:
    """A frame nested exactly MAX_DEPTH levels reaches its method."""
    reply = client.raw(_nested(MAX_DEPTH))
    assert reply["error"]["data"]["code"] == "E_INVALID_PARAMS"
    assert reply["error"]["data"]["param"] == "x"


HUGE_QUAT = [1e308, 1e308, 0.0, 0.0]
HALF = math.sqrt(0.5)


def test_huge_quaternion_components_normalise(client: RpcClient) -> None:
    """[1e308, 1e308, 0, 0] is the half-turn about (1, 1, 0): normalised without overflow."""
    added = client.call("obstacle.add", {"name": "q", "shape": BOX, "position": [2, 0, 0],
                                         "orientation": HUGE_QUAT})
    assert added["orientation"] == pytest.approx([HALF, HALF, 0, 0])
    moved = client.call("obstacle.move", {"name": "q", "position": [2, 0, 0],
                                          "orientation": [0, 0, 1e308, 1e308]})
    assert moved["orientation"] == pytest.approx([0, 0, HALF, HALF])


def test_scene_obstacle_with_huge_quaternion_still_collides(client: RpcClient) -> None:
    """A scene obstacle whose quaternion components overflow a naive norm is placed with a unit quaternion
    and blocks the robot it overlaps (a zero quaternion left it ignored by the collision checks)."""
    slab = {"name": "slab", "shape": {"type": "box", "size": [0.4, 0.4, 0.05]}, "position": [0, 0, 0.6],
            "orientation": HUGE_QUAT}
    client.call("world.loadScene", {"scene": {"version": 1, "obstacles": [slab]}})
    (placed,) = client.call("world.list")["obstacles"]
    assert placed["orientation"] == pytest.approx([HALF, HALF, 0, 0])
    report = client.call("robot.checkCollision", {"robot": "kuka", "positions": [0.0] * 7})
    assert report["collisionFree"] is False
    bodies = {side["body"] for c in report["contacts"] for side in (c["a"], c["b"])}
    assert "slab" in bodies
